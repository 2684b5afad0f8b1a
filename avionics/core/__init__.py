"""Types, units and geodesy shared by every stage: SI units and one local frame inside."""
