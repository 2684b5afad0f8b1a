"""The shell's edges: MAVLink links, frames and messages; zenoh publishing. Units convert here."""

import os

# pymavlink's mavutil picks its protocol version from this at import time; we speak MAVLink 2.
os.environ.setdefault("MAVLINK20", "1")
# ...and its parser's dialect from this one (default "all", every dialect pymavlink ships: 26 ms of start-up,
# issue 13). Our frames are decoded by avionics/io/framing.py with ardupilotmega and our own dialect; pymavlink's
# parser only reads .tlog files, whose messages we use are in common.xml.
os.environ.setdefault("MAVLINK_DIALECT", "ardupilotmega")
