"""The shell's edges: MAVLink links, frames and messages; zenoh publishing. Units convert here."""

import os

# pymavlink's mavutil picks its protocol version from this at import time; we speak MAVLink 2.
os.environ.setdefault("MAVLINK20", "1")
