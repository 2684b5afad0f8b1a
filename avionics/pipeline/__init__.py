"""The functional core (DaaCore, daa_core.py): step(now, inputs) -> StepResult, no I/O, clocks or sockets inside.
The facade (avionics/daa.py) drives it; each of its jobs is a module of this package, in the order daa_core.py lists."""
