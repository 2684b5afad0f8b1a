"""Software-in-the-loop world for the DAA module: encounter scenarios, truth trajectories, ADS-B impairments.

scenario    what an encounter is (Leg, AircraftSpec, Scenario), TOML scenario files, load_encounter()
trajectory  exact truth trajectories: leg programs and time-stamped samples
builtin     canonical encounters and those of the seed papers
daa_file    NASA DAIDALUS .daa files
impairments ADS-B-like noise, quantisation, latency and dropouts

docs/scenarios.md describes the formats and the encounters.
"""
