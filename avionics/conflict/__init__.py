"""Conflict stage: relative geometry (cpa), conflict probability (probability), trajectory prediction
(prediction), when to compute (scheduling), persistence filters (persistence) and the pipeline entry point
(assess.conflict_probabilities). docs/conflict.md."""
