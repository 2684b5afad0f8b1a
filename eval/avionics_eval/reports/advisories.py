"""Advisory reports. `python -m avionics_eval.reports.advisories closed-loop [--noise default] [--seed N]` prints,
for each built-in encounter, the RA history and the vertical miss at CPA with and without ownship flying
the RAs (the SITL response model, fast time, every MAVLink frame encoded and decoded)."""

from __future__ import annotations

import argparse
import json

from avionics.advisory.tables import load_profile
from avionics.config import load_config
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FT

ENCOUNTERS = ("head-on", "crossing-90", "overtaking", "climbing-intruder", "baek-bang-1", "baek-bang-2",
              "hwang-tracking", "radosavljevic-1", "radosavljevic-2")


def closed_loop(noise: str = "default", seed: int = 1, profile: str = "tcas2") -> dict:
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.replay import replay
    from avionics_sitl.encounters import load_encounter

    config = load_config(overrides=["zenoh.enabled=false", f'advisory.profile="{profile}"'])
    levels = {}
    for lvl in load_profile(profile).levels:  # the first row of an SL (SL 7 above FL420 shares its number)
        levels.setdefault(lvl.sl, lvl)
    rows = []
    for name in ENCOUNTERS:
        result = replay(load_encounter(name), config, PRESETS[noise], seed=seed, respond=True)
        ras = [c for c in result.changes if c.level is AdvisoryLevel.RA]
        for miss in result.misses:
            first = ras[0] if ras else None
            alim = levels[first.sensitivity_level].alim_m if first else None
            rows.append({
                "encounter": name, "intruder": miss.intruder,
                "true_hmd_m": round(miss.hmd_m, 1), "t_cpa_s": round(miss.t_cpa_s, 1),
                "first_ra_s": round(first.time_s, 1) if first else None,
                "ra_lead_s": round(miss.t_cpa_s - first.time_s, 1) if first else None,
                "ra_sequence": [c.ra_words for c in ras],
                "vmd_without_ft": round(miss.vmd_without_m / FT), "vmd_with_ft": round(miss.vmd_with_m / FT),
                "alim_ft": round(alim / FT) if alim else None,
                "alim_met": (miss.vmd_with_m >= alim) if alim else None,
            })
    return {"report": "closed-loop RA response", "profile": profile, "noise": noise, "seed": seed, "rows": rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.reports.advisories")
    sub = parser.add_subparsers(dest="report", required=True)
    p = sub.add_parser("closed-loop", help="vertical miss at CPA with and without flying the RAs")
    p.add_argument("--noise", default="default", choices=("none", "default"))
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--profile", default="tcas2")
    args = parser.parse_args(argv)
    if args.report == "closed-loop":
        print(json.dumps(closed_loop(args.noise, args.seed, args.profile), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
