"""Tracking stage: the ownship filter and one track per intruder, in the local East-North plane with
altitude kept in its own datum."""
