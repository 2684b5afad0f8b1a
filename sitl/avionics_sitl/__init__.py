"""Software-in-the-loop world for the DAA module: encounter scenarios, truth trajectories, ADS-B impairments.

aircraft    one aircraft: initial state and leg program (Leg, AircraftSpec)
trajectory  exact truth trajectories: leg programs and time-stamped samples
scenario    what an encounter is (Scenario), TOML scenario files
builtin     canonical encounters and those of the seed papers
daa_file    NASA DAIDALUS .daa files
encounters  load_encounter(): a built-in name, a .toml or a .daa file
impairments ADS-B-like noise, quantisation, latency and dropouts

docs/scenarios.md describes the formats and the encounters.
"""
