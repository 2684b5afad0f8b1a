"""The guidance stage (issue 27): what the vehicle is told to fly from the DAA's resolution advisories.

    params.py     [guidance]: mode (passive | advise | execute), floor, ceiling, quiet time, resend and ack timing
    contract.py   what an autopilot's contract gives the stage (its command mode, setpoint, stream, takeover modes)
    ardupilot.py  ArduCopter's MAVLink contract: custom modes, DO_SET_MODE, the velocity setpoint, the ack results
    px4.py        PX4's: main/sub custom modes, OFFBOARD after a setpoint stream, the LOCAL_NED velocity setpoint
    arduplane.py  ArduPlane's: GUIDED flown by acknowledged GUIDED_CHANGE_HEADING / _ALTITUDE commands (a plane has no
                  velocity setpoint)
    vertical.py   the vertical manoeuvre of the active RAs within the vehicle profile's rates, the floor and ceiling
    horizontal.py a DO-365 alerter's horizontal manoeuvre: DAIDALUS's track resolution from the guidance bands
    stage.py      the state machine (idle, commanding, holding, returning, overridden, failed) and its interlocks
    ladder.py     the mode ladder for simple vehicles (guidance.ladder): a mode per alert level, once per escalation

This slice flies TCAS-like (vertical) RAs of multicopters through ArduCopter GUIDED or PX4 OFFBOARD, and of a
fixed-wing through ArduPlane GUIDED, a DO-365 alerter's corrective and warning alerts as the bands' track
resolution (multicopters), or switches a simple vehicle's mode per alert level (PX4's DAA module's ladder)
(docs/integration.md, "Closing the loop")."""
