"""No behaviour change: every built-in encounter and every DAIDALUS conformance file gives, byte for byte, the
advisory CSV `sitl replay` wrote before the core was reshaped into components (tests/golden/, issue 12).

A difference is either a regression or a behaviour change, which regenerates the files
(`python -m tests.golden.generate`) in a commit that names it. The conformance files are read in place from
../shared (skipped where the folder is absent, failing under CI); the DAIDALUS regression reads the same replays.
"""

from __future__ import annotations

import difflib
import os

import pytest

from tests.golden.generate import CONFORMANCE, HERE, cases, replayed_csv

# one xdist worker runs both files: they read the same cached replays (tests/golden/generate.py)
pytestmark = pytest.mark.xdist_group("replays")
CASES = cases()


def test_every_case_has_a_golden_file_and_every_golden_file_a_case():
    if not CONFORMANCE.is_dir():
        reason = f"DAIDALUS conformance data not found at {CONFORMANCE}"
        if os.environ.get("CI"):
            pytest.fail(reason + ": required under CI")
        pytest.skip(reason)
    assert sorted(name for name, _, _ in CASES) == sorted(p.name for p in HERE.glob("*.csv"))


@pytest.mark.parametrize("name, encounter, args", CASES, ids=[c[0] for c in CASES])
def test_advisory_csv_is_unchanged(name, encounter, args):
    golden = (HERE / name).read_text()
    ours = replayed_csv(encounter, tuple(args))
    if ours != golden:
        diff = "".join(difflib.unified_diff(golden.splitlines(True), ours.splitlines(True), "before", "now", n=1))
        pytest.fail(f"{name}: the advisories changed:\n{diff[:4000]}")
