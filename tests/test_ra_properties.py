"""Properties of the RA logic over generated encounters with exact states (issue: "never worse than doing
nothing"), flown by the point-mass vertical simulation tests/ra_sim.py (written apart from the logic):

1. Flying the RAs never leaves a smaller true vertical miss at the horizontal CPA than not flying them
   (least over the RA threats; 15 ft tolerance for the 0.1 s simulation grid). A threat that joins an RA
   already flown is judged against the path ownship was flying when it joined: the logic cannot undo the
   manoeuvre the earlier threat needed (TCAS II v7.1 resolves the threats it has; a later one gets the best RA
   from where ownship is, e.g. a composite LEVEL OFF between a threat below and one above).
2. The first RA never crosses a threat's altitude when the non-crossing sense reaches ALIM with the
   corrective standard response (hand-coded closed form, ra_sim.corrective_separation) and that is no worse
   than doing nothing, and the descend floor (advisory/inhibits.py Floors) would not cut that descent short.
Thirty such encounters also go through the whole stack (`sitl replay --fly-ras`) in
tests/test_closed_loop.py.
"""

from __future__ import annotations

import math

from hypothesis import HealthCheck, given, settings, strategies as st

from avionics.advisory.tables import load_profile
from avionics.base.units import FPM, FT
from avionics.advisory.resolution import Threat
from ra_sim import Encounter, Intruder, corrective_separation, fly, non_crossing_sense

TCAS = load_profile("tcas2")
TOLERANCE_M = 15 * FT


@st.composite
def intruders(draw, vz_own_mps: float):
    """An intruder reaching its horizontal CPA in 25-60 s with a given miss: the relative geometry at CPA
    (HMD, VMD unflown) and the approach are drawn, the start state is traced back along straight lines."""
    t_cpa = draw(st.floats(25.0, 60.0))
    closure = draw(st.floats(30.0, 250.0))  # m/s
    bearing = draw(st.floats(0.0, 2 * math.pi))
    hmd = draw(st.floats(0.0, 1500.0))
    side = draw(st.sampled_from([-1.0, 1.0]))
    vmd = draw(st.one_of(st.just(0.0), st.floats(-800 * FT, 800 * FT)))
    vz = draw(st.one_of(st.just(0.0), st.floats(-4000 * FPM, 4000 * FPM)))
    vx, vy = -closure * math.cos(bearing), -closure * math.sin(bearing)
    # CPA point: perpendicular to the relative velocity at distance hmd
    cx, cy = side * hmd * math.sin(bearing), -side * hmd * math.cos(bearing)
    sz0 = vmd - (vz - vz_own_mps) * t_cpa
    return Intruder(cx - vx * t_cpa, cy - vy * t_cpa, vx, vy, sz0, vz)


@st.composite
def encounters(draw):
    agl = draw(st.floats(500 * FT, 12000 * FT))
    vz_own = draw(st.one_of(st.just(0.0), st.floats(-3000 * FPM, 3000 * FPM)))
    n = draw(st.sampled_from([1, 1, 1, 2]))
    intr = tuple(draw(intruders(vz_own)) for _ in range(n))
    return Encounter(agl, vz_own, intr, duration_s=65.0)


@settings(max_examples=2000, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(encounters())
def test_flying_the_ras_is_never_worse_than_not_flying_them(enc):
    out = fly(enc, TCAS)
    if not out.threats:
        return
    if out.hmd_filter_ended is not None:
        # TCAS II v7.1's HMD filter ended the RA before CPA ([B71]: it "can terminate an RA prior to ALIM being
        # obtained"), e.g. when a descent took ownship into a sensitivity level whose RA HMD is below this miss;
        # the pilot then resumes the clearance, so the vertical miss is not the RA's: the horizontal miss is the
        # protection, and it must be outside the filter, far outside the NMAC's 500 ft
        hmd, filter_hmd = out.hmd_filter_ended
        assert hmd > filter_hmd > 500 * FT
        return
    flown = min(out.vmd_flown_m[j] for j in out.threats)
    unflown = min(out.joined_miss_m[j] for j in out.threats)
    assert flown >= unflown - TOLERANCE_M, (out.words, flown / FT, unflown / FT)

    _, ra, threats, inhibits, v0, alim = out.first_ra
    sense = non_crossing_sense(threats)
    if sense is None or (sense.sign < 0 and inhibits.descend) or any(abs(th.sz_m) < 10 * FT for th in threats):
        return
    do_nothing = min(abs(v0 * th.t_cpa_s - th.sz_m - th.vz_intruder_mps * th.t_cpa_s) for th in threats)
    reach = corrective_separation(TCAS, threats, sense, v0)
    own_z = out.issued[0][3]  # ground at 0: a descent that the descend floor would cut short is not this rule's
    descent = corrective_separation(TCAS, [Threat(0.0, 0.0, max(th.t_cpa_s for th in threats))], sense, v0)
    if sense.sign < 0 and own_z - descent < TCAS.descend_inhibit_below_agl_m - TCAS.inhibit_hysteresis_m:
        return
    if reach >= alim and reach >= do_nothing:
        assert ra.sense is sense, (ra, threats)
