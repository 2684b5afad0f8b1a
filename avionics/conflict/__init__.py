"""Conflict stage: relative geometry (cpa), conflict probability (probability), trajectory prediction
(prediction), when to compute and the pre-filters (scheduling) and the pipeline entry point
(assess.conflict_probabilities). docs/conflict.md."""
