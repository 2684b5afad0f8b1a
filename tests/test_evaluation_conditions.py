"""Standard surveillance and pilot models of `avionics evaluate` (evaluate.Conditions, issue 28 item 4): the
DO-365 Appendix Q ADS-B errors are Gauss-Markov processes with DEGAS's sigma and correlation time, Mode C
altitude comes in 100 ft steps, the TCAS standard pilot flies 5 s and 0.25 g by hand, and a TRAMS pilot either
flies exactly as the default pilot or not at all."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from avionics.advisory.tables import load_profile
from avionics.base.units import FT, KT
from avionics_eval.evaluation import evaluate as ev
from avionics_eval.evaluation import generator as gen
from avionics_sitl.impairments import DEFAULT, DO365_ADSB, _meters_to_degrees
from avionics_sitl.trajectory import KinematicState

LAT, LON = 47.4, 8.5


def _errors(model, times, instances):
    """North position and east velocity errors (m, m/s) of `instances` aircraft at `times`."""
    per_m = _meters_to_degrees(LAT, 1.0, 0.0)[0]
    north, east_v = np.zeros((instances, len(times))), np.zeros((instances, len(times)))
    for i in range(instances):
        impair = model.with_seed((3, i))
        for j, t in enumerate(times):
            s = impair.impair(KinematicState(t, LAT, LON, 1000.0, 0.0, 0.0, 0.0)).state
            north[i, j], east_v[i, j] = (s.lat_deg - LAT) / per_m, s.vel_east_mps
    return north, east_v


def test_do365_adsb_errors_are_gauss_markov_with_degas_sigma_and_time_constant():
    model = replace(DO365_ADSB, dropout_probability=0.0)
    north, east_v = _errors(model, (0.0, 60.0), 500)
    rho = math.exp(-60.0 / 300.0)  # 0.819 after 60 s of a 300 s process
    for x, sigma in ((north, 75.6), (east_v, 1.22)):
        assert x.std() == pytest.approx(sigma, rel=0.08)
        assert np.corrcoef(x[:, 0], x[:, 1])[0, 1] == pytest.approx(rho, abs=0.06)
    white_north, _ = _errors(replace(DEFAULT, dropout_probability=0.0), (0.0, 60.0), 500)
    assert abs(np.corrcoef(white_north[:, 0], white_north[:, 1])[0, 1]) < 0.12  # the SITL's stay white
    used = model.with_seed(1)
    used.impair(KinematicState(0.0, LAT, LON, 1000.0, 0.0, 0.0, 0.0))
    assert used._markov and not used.with_seed(1)._markov  # a new aircraft starts its own process


def test_mode_c_altitude_comes_in_100_ft_steps_and_bad_conditions_are_refused():
    impair = ev.Conditions("do365-adsb", 100.0).impairments().with_seed(4)
    for alt_ft in (1049.0, 1051.0, 3333.0):
        s = impair.impair(KinematicState(0.0, LAT, LON, alt_ft * FT, 0.0, 0.0, 0.0))
        if s is not None:
            assert s.state.alt_msl_m / FT == pytest.approx(round(alt_ft / 100) * 100)
    assert ev.Conditions().impairments() is DEFAULT and ev.Conditions().name == "surveillance=sitl,pilot=spread"
    for bad in ({"surveillance": "radar"}, {"pilot": "robot"}, {"altitude_quantum_ft": -25.0}):
        with pytest.raises(ValueError):
            ev.Conditions(**bad)


def _co_altitude_head_on() -> gen.Encounter:
    """Level head-on at 3000 ft, 50 ft apart vertically at the CPA: an NMAC the RA resolves."""
    own = gen.Aircraft(0.0, 0.0, 3000 * FT, 0.0, 150 * KT, 0.0)
    intruder = gen.Aircraft(0.0, 0.0, 3050 * FT, math.pi, 150 * KT, 0.0)
    return gen.Encounter(7, 0, 3, 0.0, 50 * FT, 180.0, own, intruder)


def test_the_tcas_standard_pilot_flies_5_s_and_a_quarter_g_by_hand():
    """As test_evaluation's by-hand response, with the delay fixed at the standard 5 s: ownship is displaced by
    r (L - d - r / a) + r^2 / (2 a) at the CPA, L the RA's lead."""
    record = ev.evaluate(_co_altitude_head_on(), "tcas2", 11, conditions=ev.Conditions(pilot="standard"))
    response = load_profile("tcas2").response
    assert record["response_delay_s"] == response.delay_s == 5.0
    assert response.accel_mps2 == pytest.approx(0.25 * 9.80665)
    lead, d, r, a = record["ra_lead_s"], 5.0, response.rate_mps, response.accel_mps2
    displacement = (r * (lead - d - r / a) + r * r / (2 * a)) / FT
    sign = 1.0 if record["ra_words"].split("|")[0] == "DESCEND" else -1.0
    assert record["vmd_equipped_ft"] == pytest.approx(abs(50.0 + sign * displacement), abs=3.0)
    do365 = ev.evaluate(_co_altitude_head_on(), "do365", 11, conditions=ev.Conditions(pilot="standard"))
    assert do365["response_delay_s"] == 5.0  # the TCAS pilot, not the profile's 3 s


def test_a_trams_pilot_flies_as_the_default_pilot_or_not_at_all():
    e = _co_altitude_head_on()
    seen = set()
    for seed in range(8):
        trams = ev.evaluate(e, "tcas2", seed, conditions=ev.Conditions(pilot="trams"))
        spread = ev.evaluate(e, "tcas2", seed)
        assert trams["ra"] and trams["nmac_unequipped"]
        seen.add(trams["pilot_responds"])
        if trams["pilot_responds"]:
            differ = {k for k in trams if trams[k] != spread[k]}
            assert differ == {"conditions"}
        else:
            assert trams["nmac_equipped"] and trams["vmd_equipped_ft"] == trams["vmd_unequipped_ft"]
    assert seen == {True, False}
