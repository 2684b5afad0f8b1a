"""DAIDALUS's first alert times (`../shared/conformance/daidalus/first_alerts.csv`, read in place) and the
comparison of a replay's first alerts with them, for the TCAS3D and DO-365 conformance tests."""

from __future__ import annotations

import csv
import os

import pytest

from tests.golden.generate import CONFORMANCE

TOLERANCE_S = 1.0  # DAIDALUS evaluates every 0.1 s (TCAS3D) or 1 s (DO-365); the replay every 0.1 s


def golden(config: str, table: str = "first_alerts.csv") -> dict[str, list[dict]]:
    """case file -> its rows of `config` (TCAS3D, DO_365B_no_SUM, ...) in `table`; {} where the data are absent."""
    if not (CONFORMANCE / table).is_file():
        return {}
    by_file: dict[str, list[dict]] = {}
    with open(CONFORMANCE / table, newline="") as fh:
        for row in csv.DictReader(fh):
            if row["config"] == config:
                by_file.setdefault(row["case_file"], []).append(row)
    return by_file


def require(data: dict) -> None:
    """Skip with the reason where the data are absent; fail under CI (CI set)."""
    if data:
        return
    reason = f"DAIDALUS conformance data not found at {CONFORMANCE} (../shared/conformance/daidalus)"
    if os.environ.get("CI"):
        pytest.fail(reason + ": required under CI")
    pytest.skip(reason)


def problems(rows: list[dict], ours: dict[tuple[str, int], float], words: dict[int, str]) -> list[str]:
    """Every first alert of `words` (level -> name) that is missed, extra or more than TOLERANCE_S from
    DAIDALUS's; ours: (intruder name, level) -> our first time at or above that level (consumed)."""
    out = []
    for row in rows:
        for level, word in words.items():
            text = row[f"first_level{level}_sim_s"]
            theirs = float(text) if text else None
            mine = ours.pop((row["intruder"], level), None)
            if theirs is None and mine is not None:
                out.append(f"{row['intruder']}: extra {word} at {mine:.1f} s (DAIDALUS: none)")
            elif theirs is not None and mine is None:
                out.append(f"{row['intruder']}: missed {word} (DAIDALUS: {theirs:.1f} s)")
            elif theirs is not None and abs(mine - theirs) > TOLERANCE_S:
                out.append(f"{row['intruder']}: {word} at {mine:.1f} s, DAIDALUS {theirs:.1f} s")
    return out + [f"{name}: alert level {level} for an aircraft DAIDALUS does not list" for name, level in ours]
