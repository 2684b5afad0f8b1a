"""Fly again, with the code as it is now, the encounters of a results set that ended in an NMAC with DAA, and print
JSON: how many still do, which were induced, and their weights (docs/evaluation.md, "A vertical RA flown along
the mission's legs").

    python -m avionics_eval.reports.refly RESULTS [--profile do365] [--guidance-bands]

A change to the closed loop is first measured on the encounters that carry the risk ratio, in seconds of CPU
instead of hours; an NMAC it creates elsewhere is not in this count (a new run of the set is). --guidance-bands
flies a guided set's NMACs again with the guidance bands (`avionics evaluate --guidance-bands`): what the
horizontal resolution does to them (docs/evaluation.md, "The horizontal resolution flown too").
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from avionics_eval.evaluation.evaluate import Conditions, evaluate
from avionics_eval.evaluation.generator import generate
from avionics_eval.evaluation.lincoln import LincolnSource
from avionics_eval.evaluation.runner import EvaluationError, read

COLUMNS = ("hmd_flown_ft", "vmd_flown_ft")


def conditions_of(text: str) -> Conditions:
    """The manifest's conditions ("surveillance=do365-adsb,pilot=guidance,vehicle=multirotor") as Conditions."""
    fields = dict(item.split("=", 1) for item in text.split(","))
    quantum = fields.get("altitude_quantum_ft")
    return Conditions(fields["surveillance"], float(quantum) if quantum else None, fields["pilot"],
                      fields.get("vehicle"), fields.get("guidance_bands") == "on")


def encounter_source(text: str):
    """The manifest's source: "lincoln:MODELS;ownship=NAME" (a LincolnSource) or the project's generator."""
    if not text.startswith("lincoln:"):
        return None
    models, ownship = text.removeprefix("lincoln:").split(";ownship=")
    return LincolnSource.of(models, ownship)


def refly(results: Path, profile: str | None = None, guidance_bands: bool = False) -> dict:
    manifest = json.loads((results / "_manifest.json").read_text())
    profile = profile or manifest["profiles"][0]
    conditions = conditions_of(manifest["conditions"])
    if guidance_bands:
        if not conditions.guided:
            raise EvaluationError(f"--guidance-bands: {results} was not flown through the guidance "
                                  f"({conditions.name})")
        conditions = replace(conditions, guidance_bands=True)
    source = encounter_source(manifest["source"])
    seed = manifest["seed"]
    rows = [r for r in read(results).to_pylist() if r["profile"] == profile and r["nmac_equipped"]]
    out = []
    for r in rows:
        encounter = source.encounter(seed, r["index"]) if source is not None else generate(seed, r["index"])
        now = evaluate(encounter, profile, (seed, r["index"]), conditions=conditions)
        out.append({"index": r["index"], "weight": r["weight"], "induced_before": r["induced_nmac"],
                    "nmac_now": now["nmac_equipped"], "induced_now": now["induced_nmac"],
                    **{c: [r.get(c), now.get(c)] for c in COLUMNS}})

    def weight(keep):
        return sum(o["weight"] for o in out if keep(o))

    return {"results": str(results), "profile": profile, "conditions": conditions.name, "nmac_before": len(out),
            "nmac_now": sum(o["nmac_now"] for o in out), "induced_before": sum(o["induced_before"] for o in out),
            "induced_now": sum(o["induced_now"] for o in out), "weight_before": weight(lambda o: True),
            "weight_now": weight(lambda o: o["nmac_now"]),
            "induced_weight_before": weight(lambda o: o["induced_before"]),
            "induced_weight_now": weight(lambda o: o["induced_now"]), "encounters": out}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.reports.refly", description=__doc__.split("\n")[0])
    parser.add_argument("results", type=Path, help="a results directory of avionics evaluate")
    parser.add_argument("--profile", help="the profile to fly again (default: the set's first)")
    parser.add_argument("--guidance-bands", action="store_true",
                        help="a guided set: fly them with the guidance bands (avionics evaluate --guidance-bands)")
    args = parser.parse_args(argv)
    try:
        print(json.dumps(refly(args.results, args.profile, args.guidance_bands), indent=1))
    except (EvaluationError, FileNotFoundError, KeyError) as exc:
        print(f"refly: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
