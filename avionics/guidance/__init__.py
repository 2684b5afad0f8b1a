"""The guidance stage (issue 27): what the vehicle is told to fly from the DAA's resolution advisories.

    params.py     [guidance]: mode (passive | advise | execute), floor, ceiling, quiet time, resend and ack timing
    contract.py   what an autopilot's contract gives the stage (its command mode, setpoint, stream, takeover modes)
    ardupilot.py  ArduCopter's MAVLink contract: custom modes, DO_SET_MODE, the velocity setpoint, the ack results
    px4.py        PX4's: main/sub custom modes, OFFBOARD after a setpoint stream, the LOCAL_NED velocity setpoint
    vertical.py   the vertical manoeuvre of the active RAs within the vehicle profile's rates, the floor and ceiling
    horizontal.py a DO-365 alerter's horizontal manoeuvre: DAIDALUS's track resolution from the guidance bands
    stage.py      the state machine (idle, commanding, holding, returning, overridden, failed) and its interlocks

This slice flies TCAS-like (vertical) RAs of multicopters, and a DO-365 alerter's corrective and warning alerts as
the bands' track resolution, through ArduCopter GUIDED or PX4 OFFBOARD. Fixed-wing (ArduPlane GUIDED) and PX4's
mode ladder are later slices (docs/integration.md, "Closing the loop")."""
