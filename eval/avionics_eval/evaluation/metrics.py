"""Safety metrics of evaluated encounter sets, per profile, with 95 % confidence intervals (docs/evaluation.md).

Proportions: Wilson score interval (E. B. Wilson, "Probable inference, the law of succession, and statistical
inference", JASA 22(158), 1927; recommended over the Wald interval by Brown, Cai and DasGupta, Statistical
Science 16(2), 2001).

Risk ratio P(NMAC | equipped) / P(NMAC | unequipped) (the ACAS safety measure: Kuchar and Drumm, Lincoln
Laboratory Journal 16(2), 2007; ICAO Doc 9863): the two are measured on the same encounters, so the interval is
the matched-pair one, log RR +- z sqrt((b + c) / ((a + b)(a + c))) with a = NMAC both ways, b = equipped only
(induced), c = unequipped only (resolved) (Rothman and Greenland, Modern Epidemiology, 2nd ed., 1998, matched
cohort data). With no equipped NMAC, RR = 0 and the upper bound uses b = 0.5 (a continuity correction). The
loss-of-well-clear ratio (DO-365's measure of a DAA system's well-clear performance) is the same ratio of the
records' losses of DO-365 well clear.

Importance-weighted sets (the Lincoln models: any record source but generator.SOURCE) get
weighted_profile_metrics instead: an effective-sample-size Wilson interval for probabilities and the
weighted bootstrap for ratios (encounter_models/weighted.py), each figure with the encounters behind it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyarrow as pa

from avionics_eval.evaluation.generator import SOURCE

Z95 = 1.959963984540054  # two-sided 95 %


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float, float]:
    """(estimate, lower, upper) of a binomial proportion k / n; NaNs when n = 0."""
    if n == 0:
        return math.nan, math.nan, math.nan
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return p, max(0.0, centre - half), min(1.0, centre + half)


def paired_risk_ratio(a: int, b: int, c: int, z: float = Z95) -> tuple[float, float, float]:
    """(RR, lower, upper) for matched pairs: a both, b equipped only, c unequipped only (module docstring)."""
    if a + c == 0:
        return math.nan, math.nan, math.nan
    rr = (a + b) / (a + c)
    if a + b == 0:
        b_cc = 0.5
        upper = math.exp(math.log(b_cc / (a + c)) + z * math.sqrt((b_cc + c) / (b_cc * (a + c))))
        return 0.0, 0.0, upper
    se = math.sqrt((b + c) / ((a + b) * (a + c)))
    return rr, rr * math.exp(-z * se), rr * math.exp(z * se)


def load(paths, common: bool = False) -> pa.Table:
    """The records of one or more results directories (runner.run), e.g. one per profile group. common: only the
    encounters every profile has (a side-by-side comparison on the same encounters when one set is shorter)."""
    from avionics_eval.evaluation.runner import EvaluationError, read

    tables = [read(Path(p)) for p in paths]
    if any(t.schema != tables[0].schema for t in tables):
        raise EvaluationError("the results mix the guidance path (--pilot guidance) and a pilot model: report each "
                              "alone")
    table = pa.concat_tables(tables) if len(tables) > 1 else tables[0]
    encounters = list(zip(table["seed"].to_pylist(), table["index"].to_pylist()))
    profiles = table["profile"].to_pylist()
    if len(set(zip(encounters, profiles))) != table.num_rows:
        raise EvaluationError("the results hold an encounter twice for a profile: give each (set, profile) once "
                              "(two runs of one profile: report each alone)")
    if common:
        per_profile = {}
        for encounter, profile in zip(encounters, profiles):
            per_profile.setdefault(profile, set()).add(encounter)
        shared = set.intersection(*per_profile.values())
        table = table.filter(pa.array([e in shared for e in encounters]))
    return table


def _column(table: pa.Table, name: str) -> np.ndarray:
    return table[name].to_numpy(zero_copy_only=False)


def profile_metrics(table: pa.Table) -> dict:
    """The metrics of one profile's records (table already filtered to it)."""
    n = table.num_rows
    nmac_u, nmac_e = _column(table, "nmac_unequipped"), _column(table, "nmac_equipped")
    ra, alerted = _column(table, "ra"), _column(table, "alerted")
    reversals, strengthenings = _column(table, "ra_reversals"), _column(table, "ra_strengthenings")
    a, b, c = int((nmac_u & nmac_e).sum()), int((nmac_e & ~nmac_u).sum()), int((nmac_u & ~nmac_e).sum())
    n_ra, n_nmac_u = int(ra.sum()), int(nmac_u.sum())
    lead = _column(table, "ra_lead_s")[ra].astype(float)
    return {
        "encounters": n,
        "seeds": sorted(set(table["seed"].to_pylist())),
        "p_nmac_unequipped": wilson(n_nmac_u, n),
        "p_nmac_equipped": wilson(int(nmac_e.sum()), n),
        "risk_ratio": paired_risk_ratio(a, b, c),
        "nmac_counts": {"both": a, "induced": b, "resolved": c},
        "lowc_ratio": _lowc_ratio(table),
        # of the equipped NMACs, those the unequipped encounter did not have
        "induced_share": wilson(b, a + b),
        "alert_rate": wilson(int(alerted.sum()), n),
        "ra_rate": wilson(n_ra, n),
        # an RA although the unequipped miss was outside the RA's protection (HMD filter or ALIM of its SL)
        "nuisance_ra_rate": wilson(int(_column(table, "nuisance_ra").sum()), n),
        "nuisance_share_of_ras": wilson(int(_column(table, "nuisance_ra").sum()), n_ra),
        "reversal_rate": wilson(int((reversals > 0).sum()), n_ra),
        "strengthening_rate": wilson(int((strengthenings > 0).sum()), n_ra),
        # of the unequipped NMACs, those with no RA or one later than the standard response needs
        "late_ra_rate": wilson(int(_column(table, "late_ra").sum()), n_nmac_u),
        "ra_lead_s_median": float(np.median(lead)) if len(lead) else math.nan,
        "alert_duration_s_mean": float(_column(table, "alert_duration_s")[alerted].mean()) if alerted.any()
        else math.nan,
        **_mission(table, np.ones(n)),
    }


def _mission(table: pa.Table, w: np.ndarray) -> dict:
    """Records of the guidance path (guided.py): how often the guidance took the vehicle off its mission and for
    how long (the weighted mean, median and longest time not in the mission's mode, over the encounters it did;
    the encounters not back in it at the end, whose time away is cut at the encounter's end). {} otherwise."""
    if "guidance_commanded" not in table.column_names:
        return {}
    commanded = _column(table, "guidance_commanded").astype(bool)
    away = _column(table, "mission_away_s").astype(float)[commanded]
    back = _column(table, "mission_return_s")[commanded]
    back = np.array([x for x in back if x is not None and not (isinstance(x, float) and math.isnan(x))], float)
    wc = w[commanded]
    return {"mission": {
        "commanded": int(commanded.sum()),
        "commanded_rate": float(w[commanded].sum() / w.sum()) if len(w) else math.nan,
        "away_s_mean": float((wc * away).sum() / wc.sum()) if commanded.any() else math.nan,
        "away_s_median": float(np.median(away)) if commanded.any() else math.nan,
        "away_s_max": float(away.max()) if commanded.any() else math.nan,
        "return_s_median": float(np.median(back)) if len(back) else math.nan,
        "not_resumed": int((commanded & ~_column(table, "mission_resumed").astype(bool)).sum()),
    }}


BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0  # the same resamples for every ratio of a report: reproducible, and ratios comparable


def weighted_profile_metrics(table: pa.Table) -> dict:
    """The metrics of one profile's importance-weighted records (the Lincoln models, lincoln.py), table already
    filtered to it. Probabilities: weighted proportion sum(w x) / sum(w) with the effective-sample-size Wilson
    interval; ratios (risk ratio, loss-of-well-clear ratio and its parts): sum(w a) / sum(w b) with the
    weighted-bootstrap percentile interval (encounters resampled with their weights, so each pair of equipped
    and unequipped outcomes stays together) (encounter_models/weighted.py, docs/evaluation.md). `events`: the
    encounters behind each figure (for a ratio: numerator, denominator)."""
    from avionics_eval.encounter_models.weighted import weighted_proportion, weighted_ratio

    w = _column(table, "weight").astype(float)
    nmac_u, nmac_e = _column(table, "nmac_unequipped"), _column(table, "nmac_equipped")
    lowc_u, lowc_e = _column(table, "lowc_unequipped"), _column(table, "lowc_equipped")
    induced, unresolved = nmac_e & ~nmac_u, nmac_e & nmac_u
    result = {"encounters": table.num_rows, "seeds": sorted(set(table["seed"].to_pylist())),
              "sources": sorted(set(table["source"].to_pylist())), "weighted": True}
    events = {}

    def proportion(key, x):
        est = weighted_proportion(x, w)
        result[key], events[key] = (est.estimate, est.low, est.high), est.events
        return est

    def ratio(key, a, b):
        r = weighted_ratio(a, b, w, np.random.default_rng(BOOTSTRAP_SEED), BOOTSTRAP_RESAMPLES)
        result[key], events[key] = (r.estimate, r.low, r.high), (r.numerator_events, r.denominator_events)

    n_eff = proportion("p_nmac_unequipped", nmac_u).effective_n
    proportion("p_nmac_equipped", nmac_e)
    ratio("risk_ratio", nmac_e, nmac_u)
    ratio("unresolved_ratio", unresolved, nmac_u)  # the risk ratio's two parts: NMACs the DAA left ...
    ratio("induced_ratio", induced, nmac_u)        # ... and NMACs it caused
    proportion("p_unresolved_nmac", unresolved)
    proportion("p_induced_nmac", induced)
    proportion("p_lowc_unequipped", lowc_u)
    proportion("p_lowc_equipped", lowc_e)
    ratio("lowc_ratio", lowc_e, lowc_u)
    proportion("alert_rate", _column(table, "alerted"))
    proportion("ra_rate", _column(table, "ra"))
    proportion("nuisance_ra_rate", _column(table, "nuisance_ra"))
    result["effective_n"] = n_eff
    result["nmac_counts"] = {"both": int(unresolved.sum()), "induced": int(induced.sum()),
                             "resolved": int((nmac_u & ~nmac_e).sum())}
    result["events"] = events
    result.update(_mission(table, w))
    return result


def _lowc_ratio(table: pa.Table) -> tuple[float, float, float]:
    """Matched-pair ratio of losses of well clear with and without the RAs flown; NaNs for records without them."""
    if "lowc_unequipped" not in table.column_names or table["lowc_unequipped"].null_count:
        return math.nan, math.nan, math.nan
    u, e = _column(table, "lowc_unequipped"), _column(table, "lowc_equipped")
    return paired_risk_ratio(int((u & e).sum()), int((e & ~u).sum()), int((u & ~e).sum()))


def profiles_of(paths) -> list[str]:
    """The profiles of results directories in their --profiles order (runner's manifest), directory by directory."""
    from avionics_eval.evaluation.runner import MANIFEST

    found = []
    for path in paths:
        manifest = Path(path) / MANIFEST
        if manifest.exists():
            found += json.loads(manifest.read_text())["profiles"]
    return list(dict.fromkeys(found))


def metrics(table: pa.Table, order=()) -> dict:
    """{profile: profile_metrics}: the profiles of `order` first, then the others as they appear."""
    present = set(table["profile"].to_pylist())
    profiles = list(dict.fromkeys([p for p in order if p in present] + table["profile"].to_pylist()))
    mask = _column(table, "profile")
    weighted = _weighted(table)
    return {p: (weighted_profile_metrics if weighted else profile_metrics)(table.filter(pa.array(mask == p)))
            for p in profiles}


def _weighted(table: pa.Table) -> bool:
    """Whether the records are importance-weighted (any source but the project's generator); one source only,
    since weights of different models are not on one scale."""
    if "source" not in table.column_names:
        return False
    sources = {s for s in table["source"].to_pylist() if s is not None}
    if len(sources) > 1:
        from avionics_eval.evaluation.runner import EvaluationError

        raise EvaluationError(f"the results mix encounter sources ({', '.join(sorted(sources))}): report each alone")
    return bool(sources) and sources != {SOURCE}


ROWS = (  # (label, key, is a probability)
    ("P(NMAC) unequipped", "p_nmac_unequipped", True),
    ("P(NMAC) equipped (closed loop)", "p_nmac_equipped", True),
    ("risk ratio", "risk_ratio", False),
    ("loss-of-well-clear ratio", "lowc_ratio", False),
    ("induced share of equipped NMACs", "induced_share", True),
    ("alert rate (TA or RA)", "alert_rate", True),
    ("RA rate", "ra_rate", True),
    ("nuisance-RA rate (per encounter)", "nuisance_ra_rate", True),
    ("nuisance share of RAs", "nuisance_share_of_ras", True),
    ("RA reversal rate (per RA encounter)", "reversal_rate", True),
    ("RA strengthening rate (per RA encounter)", "strengthening_rate", True),
    ("late-RA rate (per unequipped NMAC)", "late_ra_rate", True),
)


WEIGHTED_ROWS = (  # (label, key): weighted sets (weighted_profile_metrics)
    ("P(NMAC) without DAA", "p_nmac_unequipped"),
    ("P(NMAC) with DAA (closed loop)", "p_nmac_equipped"),
    ("risk ratio", "risk_ratio"),
    ("  unresolved part (NMAC both ways)", "unresolved_ratio"),
    ("  induced part (NMAC with DAA only)", "induced_ratio"),
    ("P(unresolved NMAC)", "p_unresolved_nmac"),
    ("P(induced NMAC)", "p_induced_nmac"),
    ("P(LoWC) without DAA", "p_lowc_unequipped"),
    ("P(LoWC) with DAA", "p_lowc_equipped"),
    ("loss-of-well-clear ratio", "lowc_ratio"),
    ("alert rate (TA or RA)", "alert_rate"),
    ("RA rate", "ra_rate"),
    ("nuisance-RA rate", "nuisance_ra_rate"),
)


def _cell(value, events=None) -> str:
    est, lo, hi = value
    if math.isnan(est):
        return "n/a" if events is None else f"n/a ({_events(events)})"
    cell = f"{est:.4g} [{lo:.4g}, {hi:.4g}]" if events is not None else f"{est:.4f} [{lo:.4f}, {hi:.4f}]"
    return cell if events is None else f"{cell} ({_events(events)})"


def _events(events) -> str:
    return f"{events[0]}/{events[1]}" if isinstance(events, (tuple, list)) else str(events)


def weighted_markdown(result: dict) -> str:
    """Weighted metrics side by side: estimate [95 % interval] (encounters behind it; numerator/denominator for a
    ratio)."""
    profiles = list(result)
    first = result[profiles[0]]
    lines = [f"source: {', '.join(first['sources'])}", "",
             "| metric | " + " | ".join(profiles) + " |", "|---" * (len(profiles) + 1) + "|",
             "| encounters (effective n) | " + " | ".join(
                 f"{result[p]['encounters']} ({result[p]['effective_n']:.0f})" for p in profiles) + " |"]
    for label, key in WEIGHTED_ROWS:
        lines.append(f"| {label} | " + " | ".join(_cell(result[p][key], result[p]["events"][key])
                                                  for p in profiles) + " |")
    return "\n".join(lines + _mission_rows(result, profiles))


def _mission_rows(result: dict, profiles: list) -> list[str]:
    """The guidance path's rows (_mission), when the records have them."""
    if not all("mission" in result[p] for p in profiles):
        return []
    m = {p: result[p]["mission"] for p in profiles}
    return [
        "| vehicle taken off its mission by the guidance | " + " | ".join(
            f"{m[p]['commanded_rate']:.4g} ({m[p]['commanded']})" for p in profiles) + " |",
        "| time away from the mission (s): mean / median / longest | " + " | ".join(
            f"{m[p]['away_s_mean']:.1f} / {m[p]['away_s_median']:.1f} / {m[p]['away_s_max']:.1f}" for p in profiles)
        + " |",
        "| first command to back on the mission (s), median | " + " | ".join(
            f"{m[p]['return_s_median']:.1f}" for p in profiles) + " |",
        "| not back on the mission at the encounter's end | " + " | ".join(
            str(m[p]["not_resumed"]) for p in profiles) + " |",
    ]


def markdown(result: dict) -> str:
    """The metrics side by side: one column per profile, estimates with their 95 % intervals."""
    profiles = list(result)
    if profiles and result[profiles[0]].get("weighted"):
        return weighted_markdown(result)
    lines = ["| metric | " + " | ".join(profiles) + " |", "|---" * (len(profiles) + 1) + "|",
             "| encounters | " + " | ".join(str(result[p]["encounters"]) for p in profiles) + " |"]
    for label, key, _ in ROWS:
        lines.append(f"| {label} | " + " | ".join(_cell(result[p][key]) for p in profiles) + " |")
    lines.append("| NMACs: both / induced / resolved | " + " | ".join(
        "{both} / {induced} / {resolved}".format(**result[p]["nmac_counts"]) for p in profiles) + " |")
    lines.append("| median RA lead before CPA (s) | " + " | ".join(
        f"{result[p]['ra_lead_s_median']:.1f}" for p in profiles) + " |")
    lines.append("| mean alert duration (s) | " + " | ".join(
        f"{result[p]['alert_duration_s_mean']:.1f}" for p in profiles) + " |")
    return "\n".join(lines + _mission_rows(result, profiles))


def plot(table: pa.Table, result: dict, out_dir) -> list[Path]:
    """Two figures into out_dir: P(NMAC) unequipped/equipped and the risk ratio; alert rates and RA lead times."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    profiles = list(result)
    x = np.arange(len(profiles))

    def bars(ax, keys, labels, width=0.35):
        for j, (key, label) in enumerate(zip(keys, labels)):
            est = np.array([result[p][key][0] for p in profiles])
            err = np.array([[result[p][key][0] - result[p][key][1], result[p][key][2] - result[p][key][0]]
                            for p in profiles]).T
            ax.bar(x + (j - (len(keys) - 1) / 2) * width, est, width, yerr=err, capsize=4, label=label)
        ax.set_xticks(x, profiles)
        ax.legend()

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    bars(ax1, ["p_nmac_unequipped", "p_nmac_equipped"], ["unequipped", "equipped (closed loop)"])
    ax1.set_ylabel("P(NMAC) per encounter (95 % CI)")
    rr = np.array([result[p]["risk_ratio"] for p in profiles])
    ax2.errorbar(x, rr[:, 0], yerr=[rr[:, 0] - rr[:, 1], rr[:, 2] - rr[:, 0]], fmt="o", capsize=6)
    ax2.set_xticks(x, profiles)
    ax2.set_xlim(-0.5, len(profiles) - 0.5)
    ax2.set_ylabel("risk ratio (95 % CI, matched pairs)")
    ax2.axhline(1.0, color="grey", lw=0.8, ls="--")
    fig.tight_layout()
    risk = out_dir / "evaluation_risk.png"
    fig.savefig(risk, dpi=110)
    plt.close(fig)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    bars(ax1, ["alert_rate", "ra_rate", "nuisance_ra_rate"], ["alert", "RA", "nuisance RA"], width=0.25)
    ax1.set_ylabel("rate per encounter (95 % CI)")
    mask = _column(table, "profile")
    for p in profiles:
        sub = table.filter(pa.array(mask == p))
        lead = np.sort(_column(sub, "ra_lead_s")[_column(sub, "ra")].astype(float))
        ax2.step(lead, np.arange(1, len(lead) + 1) / max(len(lead), 1), where="post", label=p)
    ax2.set_xlabel("first RA before the CPA (s)")
    ax2.set_ylabel("fraction of RA encounters")
    ax2.legend()
    fig.tight_layout()
    alerts = out_dir / "evaluation_alerts.png"
    fig.savefig(alerts, dpi=110)
    plt.close(fig)
    return [risk, alerts]
