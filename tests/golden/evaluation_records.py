"""Evaluation records frozen before the guidance path was added to `avionics evaluate` (issue 27 item 4): the
records of the pilot models must not change when the option is off (tests/test_evaluation_guidance.py).
Regenerate (`python -m tests.golden.evaluation_records`) only in a commit that says why the records change."""

from __future__ import annotations

import json
from pathlib import Path

PATH = Path(__file__).with_name("evaluation_records.json")
# (source: None = ours, else (models, ownship)), seed, indices, profiles, conditions (surveillance, quantum, pilot)
CASES = (
    (None, 1, (0, 1, 2), ("tcas2", "do365"), ("sitl", None, "spread")),
    (("uncor_1200exclude_rotorcraft_v1p2.txt", "uav-survey"), 28, (3, 7), ("small-uas", "do365"),
     ("do365-adsb", None, "standard")),
    (("uncor_1200exclude_rotorcraft_v1p2.txt", "uav-survey"), 28, (7,), ("small-uas",), ("do365-adsb", 100.0, "trams")),
)


def records() -> list[dict]:
    from avionics_eval.evaluation.evaluate import Conditions, evaluate
    from avionics_eval.evaluation.generator import generate
    from avionics_eval.evaluation.lincoln import LincolnSource

    out = []
    for source, seed, indices, profiles, conditions in CASES:
        lincoln = LincolnSource.of(*source) if source is not None else None
        for index in indices:
            encounter = generate(seed, index) if lincoln is None else lincoln.encounter(seed, index)
            for profile in profiles:
                out.append(evaluate(encounter, profile, (seed, index), conditions=Conditions(*conditions)))
    return out


if __name__ == "__main__":
    PATH.write_text(json.dumps(records(), indent=0, sort_keys=True) + "\n")
    print(f"wrote {PATH}")
