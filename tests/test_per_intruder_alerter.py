"""DAIDALUS's per-intruder alerter (issue 30 item 5, advisory/alerting.py Alerter.non_cooperative): under `do365`
an intruder seen only by the ownship's sensors is judged by DO-365B's DWC_Non_Coop (2200 ft, 450 ft, no tau), the
others by DWC_Phase_I (0.66 nmi, 450/700 ft, 35 s). Oracles: the conf's thresholds by hand, and each alerter alone
on its own rows (the split must not mix rows, levels or hysteresis history)."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from avionics.advisory.alerting import Encounter
from avionics.advisory.tables import profile_text
from avionics.base.units import FT
from avionics.compose import build_components
from avionics.config import ConfigError, load_config
from avionics.conflict.cpa import pair_geometry_reference

DO365 = build_components(load_config(overrides=["advisory.profile=do365"]), Counter())
ALERTER = DO365.alerter
LEVEL = DO365.profile.levels[0]


def encounter(s_xy, v_xy, sz, vz, non_coop) -> Encounter:
    n = len(sz)
    return Encounter(pair_geometry_reference(s_xy, v_xy, sz, vz), np.ones(n, bool), 0.0, True, None,
                     np.asarray(non_coop, bool))


def test_do365_judges_sensor_only_traffic_by_dwc_non_coop_and_adsb_traffic_by_phase_i():
    """An aircraft 3000 ft away, co-altitude, holding station (no closure): inside Phase I's 0.66 nmi (4010 ft)
    disk, so well clear is lost now, the warning (level 3); outside Non_Coop's 2200 ft disk and with no tau term,
    so nothing. At 2000 ft both are inside: warning for both."""
    assert ALERTER.non_cooperative is not None and ALERTER.non_cooperative.name == "do365-non-coop"
    for distance_ft, expected in ((3000.0, [3, 0]), (2000.0, [3, 3])):
        s = np.array([[distance_ft * FT, 0.0]] * 2)
        enc = encounter(s, np.zeros((2, 2)), np.zeros(2), np.zeros(2), [False, True])
        assert ALERTER.alert(enc, LEVEL).tolist() == expected


@settings(max_examples=200)
@given(st.data())
def test_each_intruder_gets_the_level_its_own_alerter_gives_it(data):
    n = data.draw(st.integers(1, 8))
    coord = st.floats(-15000.0, 15000.0)
    s = np.array([[data.draw(coord), data.draw(coord)] for _ in range(n)])
    v = np.array([[data.draw(st.floats(-150.0, 150.0)), data.draw(st.floats(-150.0, 150.0))] for _ in range(n)])
    sz = np.array([data.draw(st.floats(-600.0, 600.0)) for _ in range(n)])
    vz = np.array([data.draw(st.floats(-20.0, 20.0)) for _ in range(n)])
    nc = np.array([data.draw(st.booleans()) for _ in range(n)])
    previous = np.array([data.draw(st.integers(0, 3)) for _ in range(n)])
    both = encounter(s, v, sz, vz, nc)
    got = ALERTER.alert(both, LEVEL, previous=previous)
    held, continued = ALERTER.hold(both, LEVEL, previous, np.zeros(n, int))
    cooperative = type(ALERTER)(ALERTER.name, ALERTER.levels)  # the same levels without the per-intruder split
    for i in range(n):
        alone = ALERTER.non_cooperative if nc[i] else cooperative
        one = encounter(s[i:i + 1], v[i:i + 1], sz[i:i + 1], vz[i:i + 1], [False])
        assert got[i] == alone.alert(one, LEVEL, previous=previous[i:i + 1])[0]
        h, c = alone.hold(one, LEVEL, previous[i:i + 1], np.zeros(1, int))
        assert (held[i], continued[i]) == (h[0], c[0])


def test_a_non_cooperative_alerter_that_differs_in_levels_or_hysteresis_is_refused(tmp_path):
    text = profile_text("do365-non-coop")[1]
    for change, words in ((("alerting_m = 2", "alerting_m = 1"), "hysteresis"),
                          (('name = "WARNING"', 'name = "ALARM"'), "same levels")):
        bad = tmp_path / "bad-non-coop.toml"
        bad.write_text(text.replace(*change))
        main = tmp_path / "main.toml"
        main.write_text(profile_text("do365")[1].replace(
            'non_cooperative = "do365-non-coop"', f'non_cooperative = "{bad}"'))
        with pytest.raises(ConfigError, match=words):  # at load: `avionics config` refuses it, not `run`
            load_config(overrides=[f'advisory.profile="{main}"'])
    assert math.isclose(ALERTER.non_cooperative.levels[0].thresholds.dthr_m, 2200 * FT)
