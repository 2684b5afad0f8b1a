"""Conflict stage: relative geometry (CPA, tau) of every ownship-intruder pair."""
