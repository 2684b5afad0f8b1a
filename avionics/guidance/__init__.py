"""The guidance stage (issue 27): what the vehicle is told to fly from the DAA's resolution advisories.

    params.py     [guidance]: mode (passive | advise | execute), floor, ceiling, quiet time, resend and ack timing
    ardupilot.py  ArduCopter's MAVLink contract: custom modes, DO_SET_MODE, the velocity setpoint, the ack results
    vertical.py   the vertical manoeuvre of the active RAs within the vehicle profile's rates, the floor and ceiling
    stage.py      the state machine (idle, commanding, holding, returning, overridden, failed) and its interlocks

This slice flies TCAS-like (vertical) RAs through ArduCopter GUIDED. PX4 OFFBOARD, fixed-wing (ArduPlane) and the
DO-365 horizontal resolutions are later slices (docs/integration.md, "Closing the loop")."""
