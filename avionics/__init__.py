"""Open detect-and-avoid (DAA) module for unmanned aircraft.

ADS-B traffic and ownship state come in over MAVLink; one track per intruder,
CPA/tau assessment and TCAS-like TA/RA advisories go out on MAVLink and zenoh.
"""

__version__ = "0.1.0"
