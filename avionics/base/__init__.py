"""The base layer: the types, units, geodesy, frame, comparisons, parameters and kernel switch every stage shares
(SI units and one local frame inside). Named "base", not "core": the core is the pipeline (avionics/pipeline/).
"""
