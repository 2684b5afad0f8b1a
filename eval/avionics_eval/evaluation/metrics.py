"""Safety metrics of evaluated encounter sets, per profile, with 95 % confidence intervals (docs/evaluation.md).

Proportions: Wilson score interval (E. B. Wilson, "Probable inference, the law of succession, and statistical
inference", JASA 22(158), 1927; recommended over the Wald interval by Brown, Cai and DasGupta, Statistical
Science 16(2), 2001).

Risk ratio P(NMAC | equipped) / P(NMAC | unequipped) (the ACAS safety measure: Kuchar and Drumm, Lincoln
Laboratory Journal 16(2), 2007; ICAO Doc 9863): the two are measured on the same encounters, so the interval is
the matched-pair one, log RR +- z sqrt((b + c) / ((a + b)(a + c))) with a = NMAC both ways, b = equipped only
(induced), c = unequipped only (resolved) (Rothman and Greenland, Modern Epidemiology, 2nd ed., 1998, matched
cohort data). With no equipped NMAC, RR = 0 and the upper bound uses b = 0.5 (a continuity correction).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyarrow as pa

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
    from avionics_eval.evaluation.runner import read

    tables = [read(Path(p)) for p in paths]
    table = pa.concat_tables(tables) if len(tables) > 1 else tables[0]
    encounters = list(zip(table["seed"].to_pylist(), table["index"].to_pylist()))
    profiles = table["profile"].to_pylist()
    if len(set(zip(encounters, profiles))) != table.num_rows:
        raise ValueError("the results hold an encounter twice for a profile: give each (set, profile) once")
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
    }


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
    return {p: profile_metrics(table.filter(pa.array(mask == p))) for p in profiles}


ROWS = (  # (label, key, is a probability)
    ("P(NMAC) unequipped", "p_nmac_unequipped", True),
    ("P(NMAC) equipped (closed loop)", "p_nmac_equipped", True),
    ("risk ratio", "risk_ratio", False),
    ("induced share of equipped NMACs", "induced_share", True),
    ("alert rate (TA or RA)", "alert_rate", True),
    ("RA rate", "ra_rate", True),
    ("nuisance-RA rate (per encounter)", "nuisance_ra_rate", True),
    ("nuisance share of RAs", "nuisance_share_of_ras", True),
    ("RA reversal rate (per RA encounter)", "reversal_rate", True),
    ("RA strengthening rate (per RA encounter)", "strengthening_rate", True),
    ("late-RA rate (per unequipped NMAC)", "late_ra_rate", True),
)


def _cell(value) -> str:
    est, lo, hi = value
    if math.isnan(est):
        return "n/a"
    return f"{est:.4f} [{lo:.4f}, {hi:.4f}]"


def markdown(result: dict) -> str:
    """The metrics side by side: one column per profile, estimates with their 95 % intervals."""
    profiles = list(result)
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
    return "\n".join(lines)


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
