"""Dai et al. 2017 Table 2 reproduced: `python -m avionics_eval.reports.fusion [--runs 60] [--markdown]`.

RMSE (east, north, height) and false/leak alarm counts of the sensor-only, ADS-B-only and fused tracks, with the
fixed (1 s) and the variable sampling period (Dai Sec. 2.3, Table 1: fusion.sampling_period), clean and under
each ADS-B failure mode of Dai Sec. 3.7 (step, ramp, oscillation, loss), for two sensors: DO-365 Appendix Q
active surveillance (Dai's "TCAS") and radar (avionics_sitl.sensors, as DEGAS codes them). Prints JSON (or, with
--markdown, the table of docs/tracking.md).

**Our scenario, not Dai's.** Dai give their scenario only in outline (3000 s, the intruder 270 km away climbing
from 300 m, "TCAS noise 50 m", a time-varying ADS-B noise) and no encounter geometry, and a TCAS whose error is
50 m is not one: Appendix Q's active surveillance measures bearing to 9-15 degrees. So the runs here are an
encounter of their kind, cut to what alerting needs: a UAV at 1000 m flying north at 40 m/s, an intruder
(60-90 m/s) that climbs 300 m at 5 m/s from the start and levels (Dai: "climbs gradually, then cruises"), flies
an S-turn (3 deg/s for 10 s each way) from 60 to 80 s (Dai's manoeuvre between steps 12500 and 12650), and
reaches its closest point at 100 s (0-150 m horizontally, +-30 m vertically) from a bearing within 50 degrees of
the nose; 130 s per run, truth every 0.1 s, a new geometry and new error draws per run.

**Local filters** are the project's IMM banks (imm.ImmBank; [tracking] defaults: CV + CT horizontally, CH + CAD
vertically, the radar's also with the standard-rate turns, as the live tracker's; Dai run CV, CA and CS with VB
noise) sampled as Dai sample them: every sampling period each filter
takes its newest measurement (ADS-B: DO-260B's 2 Hz position with sitl's DEFAULT errors, NACp 9 / NACv 2, 5 %
dropouts; active surveillance: 1 Hz, every 5 s while tau >= 60 s; radar: 10 Hz scans) at its own time of
applicability. The sensor's measurement is the converted one of tracking/measurement.py. The ADS-B reports all
pass the integrity monitor (tracking/integrity.py), whose fault size widens ADS-B's covariance in the fusion
(IntegrityMonitor.widen). One aircraft per run: association is tested apart (tests/test_polar_tracking.py), so
false returns play no part here; missed detections do.

**Fused** = fusion.fuse (Dai eqs 41-42 with P_12 = 0, and covariance intersection as `fused-ci`), with the
consistency gate and the monitor's verdict; evaluated every second from 10 s.

**Alarms** (Dai Sec. 3.6): at every evaluation time whose true range tau (slant range over its closing rate) lies
in the RA interval (tau < 35 s) or the TA interval (35-45 s), a system's estimated tau more than 1 s below the true
one is a false alarm, more than 1 s above a leak alarm; counted over all runs.

Faults from 50 s on ADS-B's positions, sized as the integrity report's (reports/tracking.py: STEP_M, RAMP_MPS,
OSC_AMPLITUDE_M, OSC_PERIOD_S) in a random direction; loss: no ADS-B after 50 s.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import time

import numpy as np

from avionics.compose import motion_models
from avionics.config import load_config
from avionics.tracking import fusion, models
from avionics.tracking.imm import ImmBank
from avionics.tracking.imm_tracker import assemble
from avionics.tracking.integrity import IntegrityMonitor
from avionics.tracking.measurement import about_prediction, ground_polar, to_tracking_frame
from avionics.tracking.record import UNKNOWN_SPEED_SIGMA_MPS, UNKNOWN_VRATE_SIGMA_MPS
from avionics_eval.reports.tracking import OSC_AMPLITUDE_M, OSC_PERIOD_S, RAMP_MPS, STEP_M
from avionics_sitl.impairments import DEFAULT
from avionics_sitl.sensors import MODELS, SimulatedSensor

DT = 0.1
DURATION_S = 130.0
T_CPA_S = 100.0
FAULT_ONSET_S = 50.0
EVAL_FROM_S = 10.0
OWN_ALT_M, OWN_V = 1000.0, np.array([0.0, 40.0, 0.0])
ADSB_PERIOD_S = 0.5  # DO-260B airborne position: twice a second
RA_TAU_S, TA_TAU_S, ALARM_SLACK_S = 35.0, 45.0, 1.0  # Dai Sec. 3.6
FAULTS = ("clean", "step", "ramp", "oscillation", "loss")
SAMPLING = ("fixed", "variable")
SYSTEMS = ("sensor", "adsb", "fused", "fused-ci")
DAI_TABLE_2 = {  # Dai Table 2: longitude, latitude, height RMSE (m); false RA, leak RA, false TA, leak TA
    "FIMM-TCAS": [29.8684, 26.0890, 26.6773, 376, 330, 291, 302],
    "FIMM-ADS-B": [16.5508, 16.3195, 15.9397, 198, 195, 185, 152],
    "FIMM-Fusion": [14.2319, 13.1903, 13.1918, 132, 151, 158, 148],
    "VIMM-TCAS": [19.0613, 17.9499, 17.9382, 226, 189, 221, 173],
    "VIMM-ADS-B": [11.1504, 10.3604, 10.7635, 165, 156, 158, 130],
    "VIMM-Fusion": [9.1981, 8.3820, 8.1759, 73, 72, 123, 88],
}


def own_state(t) -> np.ndarray:
    t = np.asarray(t, float)[..., None]
    return np.concatenate([np.array([0.0, 0.0, OWN_ALT_M]) + OWN_V * t, np.broadcast_to(OWN_V, t.shape[:-1] + (3,))], -1)


def intruder_truth(rng, times) -> np.ndarray:
    """(K, 6) [e, n, alt, ve, vn, vu] of one run's intruder (module docstring)."""
    speed = rng.uniform(60.0, 90.0)
    az0 = math.radians(rng.uniform(-50.0, 50.0))
    heading = np.full(len(times), az0 + math.pi)  # towards the ownship from bearing az0
    turn = math.radians(3.0)
    heading += np.where(times >= 60.0, turn * np.minimum(times - 60.0, 10.0), 0.0)
    heading -= np.where(times >= 70.0, turn * np.minimum(times - 70.0, 10.0), 0.0)
    ve, vn = speed * np.sin(heading), speed * np.cos(heading)
    vu = np.where(times < 60.0, 5.0, 0.0)
    pos = np.stack([np.cumsum(ve), np.cumsum(vn), np.cumsum(vu)], axis=1) * DT
    k_cpa = int(round(T_CPA_S / DT))
    target = own_state(T_CPA_S)[:3] + np.array([rng.uniform(-150.0, 150.0), 0.0, rng.uniform(-30.0, 30.0)])
    pos += target - pos[k_cpa]
    return np.concatenate([pos, np.stack([ve, vn, vu], axis=1)], axis=1)


def range_tau(x: np.ndarray, own: np.ndarray) -> np.ndarray:
    """Slant range tau (s) of intruder states x (..., 6) from the ownship's own (..., 6); inf when not closing."""
    rel, vrel = x[..., :3] - own[..., :3], x[..., 3:6] - own[..., 3:6]
    r2 = (rel * rel).sum(-1)
    closing = (rel * vrel).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(closing < 0.0, -r2 / closing, np.inf)


def adsb_fault(kind: str, rng, times) -> tuple[np.ndarray, np.ndarray]:
    """(K, 2) position offsets and (K,) kept flags of one run's ADS-B under `kind` from FAULT_ONSET_S."""
    angle = rng.uniform(0.0, 2 * math.pi)
    u = np.array([math.cos(angle), math.sin(angle)])
    tau = np.maximum(times - FAULT_ONSET_S, 0.0)
    after = times >= FAULT_ONSET_S
    size = np.zeros(len(times))
    if kind == "step":
        size = np.where(after, rng.uniform(*STEP_M), 0.0)
    elif kind == "ramp":
        size = rng.uniform(*RAMP_MPS) * tau
    elif kind == "oscillation":
        size = rng.uniform(*OSC_AMPLITUDE_M) * np.sin(2 * math.pi * tau / rng.uniform(*OSC_PERIOD_S))
    keep = ~after if kind == "loss" else np.ones(len(times), bool)
    return size[:, None] * u, keep


class Local:
    """One local filter per run (bank slot = run): the IMM banks, sampled by period, fed a run's measurements.
    kind: "adsb", "radar" or "active", whose horizontal modes and switching the live tracks of that kind have
    (TrackingConfig.modes_for)."""

    def __init__(self, runs: int, cfg, kind: str):
        # the configured motion models (compose.py) at [tracking]'s 1 s values: fixed sampling takes one a second
        modes, switch = cfg.modes_for(kind)
        h, v = motion_models(cfg, 1.0, modes)
        m_h, m_v = models.bank_switching(h, v, switch, cfg.imm_turn_exit_probability)
        self.bank_h = ImmBank(h, 4, m_h, capacity=runs, compiled=False)
        self.bank_v = ImmBank(v, 2, m_v, capacity=runs, compiled=False)
        self.t = np.full(runs, np.nan)  # time of each run's last update (NaN: not started)
        self.accel0 = cfg.imm_initial_accel_sigma_mps2

    def apply(self, runs, t, z_h, m_h, r_h, z_v, m_v, r_v, polar=None) -> None:
        """Measurements of these runs at times t: z_h (B, 4) [e, n, ve, vn] with mask and covariance r_h (B, 4, 4);
        z_v (B, 2) [alt, vu] with mask and variances r_v (B, 2); polar (B, 6) [ground range, its sigma, bearing,
        its sigma, ownship e, n] of a measurement without elevation (else NaN), which updates a started filter as
        the EKF linearised at its prediction, as the live sensor tracker does (SensorTracker._relinearise).
        Starts a run's filter at its first."""
        new = np.isnan(self.t[runs])
        if polar is not None and (lin := ~new & np.isfinite(polar[:, 0])).any():
            xh, _, _ = self.bank_h.predict(runs[lin], t[lin] - self.t[runs[lin]])
            q = polar[lin]
            z, r = about_prediction(q[:, 0], q[:, 1], q[:, 2], q[:, 3], xh[:, :2] - q[:, 4:6])
            z_h, r_h = z_h.copy(), r_h.copy()
            z_h[lin, :2], r_h[lin, :2, :2] = z + q[:, 4:6], r
        if new.any():
            s = runs[new]
            x = np.zeros((len(s), 6))
            x[:, :4] = np.where(m_h[new], z_h[new], 0.0)
            var = np.full((len(s), 6), self.accel0**2)
            var[:, :4] = np.where(m_h[new], np.diagonal(r_h[new], axis1=1, axis2=2), UNKNOWN_SPEED_SIGMA_MPS**2)
            p = var[:, :, None] * np.eye(6)
            p[:, :2, :2] = r_h[new][:, :2, :2]
            self.bank_h.init(s, x, p)
            var_v = np.where(m_v[new], r_v[new], np.array([r_v[new][:, 0].max(), UNKNOWN_VRATE_SIGMA_MPS**2]))
            self.bank_v.init(s, np.where(m_v[new], z_v[new], 0.0), var_v[:, :, None] * np.eye(2))
            self.t[s] = t[new]
        old = ~new
        if old.any():
            s = runs[old]
            dt = t[old] - self.t[s]
            self.bank_h.commit(self.bank_h.update(s, dt, z_h[old], m_h[old], np.ones((len(s), 4)), r_cov=r_h[old]))
            self.bank_v.commit(self.bank_v.update(s, dt, z_v[old], m_v[old], r_v[old]))
            self.t[s] = t[old]

    def predict(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        slots = np.arange(len(self.t))
        dt = t - self.t
        xh, ph, _ = self.bank_h.predict(slots, dt)
        xv, pv, _ = self.bank_v.predict(slots, dt)
        return assemble(xh, ph, xv, pv)


def simulate_sensor(kind: str, truths, seed: int):
    """Per run: the sensor's detections as (times (K,), z_h (K, 4), mask_h, r_h (K, 4, 4), z_v (K, 2), mask_v,
    r_v (K, 2), declared position sigma (K,))."""
    errors = MODELS[kind]
    out = []
    for run, truth in enumerate(truths):
        sensor = SimulatedSensor(errors, kind, seed=(seed, run, 1 if kind == "radar" else 2))
        k_step, rows, k = max(1, int(round(1.0 / errors.rate_hz / DT))), [], 0
        while k < len(truth):
            tk = round(k * DT, 6)
            own = own_state(tk)
            meas, who = sensor.scan(tk, own, 0.0, truth[k][None])
            if meas and who[0] == 0:
                rows.append((tk, meas[0], own))
            period = errors.period_s(float(range_tau(truth[k], own)))
            k += max(k_step, int(round(period / DT)))
        times = np.array([r[0] for r in rows])
        own_enu = np.array([r[2][:3] for r in rows])
        z_hh, r_hh, z_vv, r_vv = to_tracking_frame([r[1] for r in rows], own_enu, 0.0)
        n = len(rows)
        z_h, r_h = np.zeros((n, 4)), np.tile(np.eye(4), (n, 1, 1))
        z_h[:, :2], r_h[:, :2, :2] = z_hh, r_hh
        m_h = np.zeros((n, 4), bool)
        m_h[:, :2] = True
        z_v, r_v = np.zeros((n, 2)), np.ones((n, 2))
        z_v[:, 0], r_v[:, 0] = z_vv, r_vv
        m_v = np.zeros((n, 2), bool)
        m_v[:, 0] = True
        sigma = np.sqrt(0.5 * (r_hh[:, 0, 0] + r_hh[:, 1, 1]))
        polar = np.full((n, 6), np.nan)
        if n and rows[0][1].elevation_rad is None:  # active surveillance: relinearised at each update (Local.apply)
            polar[:, :4] = np.stack(ground_polar([r[1] for r in rows], own_enu, 0.0), axis=1)
            polar[:, 4:6] = own_enu[:, :2]
        out.append((times, z_h, m_h, r_h, z_v, m_v, r_v, sigma, polar))
    return out


def simulate_adsb(truths, fault: str, seed: int, cfg):
    """Per run: ADS-B reports (every ADSB_PERIOD_S, DEFAULT errors and dropouts) with the fault applied, in the
    layout of simulate_sensor; plus the reports' plane positions and velocities for the integrity monitor."""
    out = []
    k_step = int(round(ADSB_PERIOD_S / DT))
    for run, truth in enumerate(truths):
        rng = np.random.default_rng((seed, run, 3, FAULTS.index(fault)))
        idx = np.arange(0, len(truth), k_step)
        times = idx * DT
        x = truth[idx]
        offset, keep = adsb_fault(fault, np.random.default_rng((seed, run, 4)), times)
        keep &= rng.random(len(idx)) >= DEFAULT.dropout_probability
        n = len(idx)
        z_h = np.empty((n, 4))
        z_h[:, :2] = x[:, :2] + rng.normal(0.0, DEFAULT.position_sigma_m, (n, 2)) + offset
        z_h[:, 2:] = x[:, 3:5] + rng.normal(0.0, DEFAULT.velocity_sigma_mps, (n, 2))
        z_v = np.stack([np.round(x[:, 2] / DEFAULT.altitude_quantum_m) * DEFAULT.altitude_quantum_m,
                        x[:, 5] + rng.normal(0.0, DEFAULT.vertical_rate_sigma_mps, n)], axis=1)
        r_h = np.diag([DEFAULT.position_sigma_m**2] * 2 + [DEFAULT.velocity_sigma_mps**2] * 2)
        r_v = np.array([cfg.altitude_sigma_m**2, cfg.vertical_rate_sigma_mps**2])
        k = np.flatnonzero(keep)
        out.append((times[k], z_h[k], np.ones((len(k), 4), bool), np.broadcast_to(r_h, (len(k), 4, 4)), z_v[k],
                    np.ones((len(k), 2), bool), np.broadcast_to(r_v, (len(k), 2)),
                    np.full(len(k), DEFAULT.position_sigma_m)))
    return out


def run_local(meas, sampling: str, cfg, kind: str, monitor: IntegrityMonitor | None = None):
    """Sample each run's measurements (of surveillance `kind`: "adsb", "radar", "active") with the fixed or
    variable period; returns the filter's predictions on the evaluation grid: times (G,), x (G, R, 6), P (G, R, 6, 6) and, with the integrity monitor (ADS-B), each run's
    degraded flag (G, R) (P then widened by the monitor's fault size, IntegrityMonitor.widen)."""
    runs = len(meas)
    local = Local(runs, cfg, kind)
    grid_t = np.arange(EVAL_FROM_S, DURATION_S + 1e-9, 1.0)
    next_t = np.zeros(runs)
    ptr = np.zeros(runs, int)  # first measurement not yet used
    adsb_ptr = np.zeros(runs, int)  # the integrity monitor sees every report
    keys = list(range(runs))
    xs, ps, degraded = [], [], []
    g = 0
    for k in range(int(round(DURATION_S / DT)) + 1):
        tick = round(k * DT, 6)
        if monitor is not None:
            _observe(monitor, meas, adsb_ptr, tick)
            monitor.check_silence(tick)
        due = np.flatnonzero(next_t <= tick + 1e-9)
        take, at = [], []
        for r in due:
            times = meas[r][0]
            j = int(np.searchsorted(times, tick + 1e-9, side="right")) - 1  # newest at or before tick
            if j >= ptr[r]:
                take.append(r)
                at.append(j)
                ptr[r] = j + 1
        if take:
            take_a, at_a = np.array(take), np.array(at)
            cols = [np.stack([meas[r][c][j] for r, j in zip(take, at)]) for c in range(len(meas[take[0]]))]
            local.apply(take_a, cols[0], *cols[1:7], *cols[8:])
            if sampling == "variable":
                x, _ = local.predict(tick)
                sigma = cols[7]
                if monitor is not None:
                    sigma = np.hypot(sigma, [monitor.status(int(r)).fault_m for r in take])
                tau = range_tau(x[take_a], own_state(tick))
                next_t[take_a] = tick + fusion.sampling_period(sigma, tau)
            else:
                next_t[take_a] = tick + 1.0
        if g < len(grid_t) and abs(tick - grid_t[g]) < 1e-6:
            x, p = local.predict(tick)
            if monitor is not None:
                p = monitor.widen(keys, p)
                degraded.append([monitor.status(r).degraded for r in keys])
            xs.append(x)
            ps.append(p)
            g += 1
    return grid_t, np.array(xs), np.array(ps), np.array(degraded) if monitor is not None else None


def _observe(monitor: IntegrityMonitor, meas, ptr, tick) -> None:
    """Every ADS-B report received by tick goes through the integrity monitor (one batch per report time)."""
    batch = []
    for r, m in enumerate(meas):
        times = m[0]
        while ptr[r] < len(times) and times[ptr[r]] <= tick + 1e-9:
            batch.append((r, ptr[r]))
            ptr[r] += 1
    if batch:
        rs = [r for r, _ in batch]
        zs = np.array([meas[r][1][j] for r, j in batch])
        ts = np.array([meas[r][0][j] for r, j in batch])
        monitor.observe(rs, ts, ts, zs[:, 0], zs[:, 1], zs[:, 2:4], np.array([meas[r][7][j] for r, j in batch]))


def scores(grid_t, x, truths) -> dict:
    """RMSE per axis over runs and the grid (Dai eq 43, averaged over steps) and the alarm counts (Sec. 3.6)."""
    k = np.round(grid_t / DT).astype(int)
    truth = np.stack([tr[k] for tr in truths], axis=1)  # (G, R, 6)
    own = own_state(grid_t)[:, None, :]
    err = x[..., :3] - truth[..., :3]
    rmse = np.sqrt(np.nanmean(err**2, axis=(0, 1)))
    tau_true, tau_est = range_tau(truth, own), range_tau(x, own)
    ra = tau_true < RA_TAU_S
    ta = (tau_true >= RA_TAU_S) & (tau_true < TA_TAU_S)
    early, late = tau_est < tau_true - ALARM_SLACK_S, tau_est > tau_true + ALARM_SLACK_S
    return {"rmse_east_m": round(float(rmse[0]), 2), "rmse_north_m": round(float(rmse[1]), 2),
            "rmse_height_m": round(float(rmse[2]), 2),
            "false_ra": int((ra & early).sum()), "leak_ra": int((ra & late).sum()),
            "false_ta": int((ta & early).sum()), "leak_ta": int((ta & late).sum())}


def report(runs: int = 60, seed: int = 2017) -> dict:
    cfg = load_config().tracking
    t0 = time.process_time()
    times = np.round(np.arange(0.0, DURATION_S + 1e-9, DT), 6)
    truths = [intruder_truth(np.random.default_rng((seed, r)), times) for r in range(runs)]
    rows: dict = {}
    adsb_runs = {}
    for sampling in SAMPLING:
        for fault in FAULTS:
            monitor = IntegrityMonitor(cfg.velocity_sigma_mps, runs)
            adsb_runs[sampling, fault] = run_local(simulate_adsb(truths, fault, seed, cfg), sampling, cfg, "adsb",
                                                   monitor)
    for kind in ("active", "radar"):
        meas = simulate_sensor(kind, truths, seed)
        for sampling in SAMPLING:
            grid_t, xs, ps, _ = run_local(meas, sampling, cfg, kind)
            for fault in FAULTS:
                _, xa, pa, deg = adsb_runs[sampling, fault]
                cell = {"sensor": scores(grid_t, xs, truths), "adsb": scores(grid_t, xa, truths)}
                for name, cross in (("fused", "independent"), ("fused-ci", "ci")):
                    g, r = xs.shape[:2]
                    xf, _, w, ok = fusion.fuse(xa.reshape(g * r, 6), pa.reshape(g * r, 6, 6), xs.reshape(g * r, 6),
                                               ps.reshape(g * r, 6, 6), deg.reshape(g * r), cross=cross)
                    cell[name] = scores(grid_t, xf.reshape(g, r, 6), truths)
                    cell[name]["mean_adsb_weight"] = round(float(w.mean()), 3)
                    cell[name]["inconsistent_share"] = round(float(1.0 - ok.mean()), 3)
                rows.setdefault(kind, {}).setdefault(sampling, {})[fault] = cell
    return {
        "command": f"python -m avionics_eval.reports.fusion --runs {runs} --seed {seed}",
        "date": datetime.date.today().isoformat(),
        "runs": runs,
        "cpu_s": round(time.process_time() - t0, 1),
        "scenario": {"duration_s": DURATION_S, "t_cpa_s": T_CPA_S, "fault_onset_s": FAULT_ONSET_S,
                     "evaluated_from_s": EVAL_FROM_S, "ra_tau_s": RA_TAU_S, "ta_tau_s": TA_TAU_S},
        "rows": rows,
        "dai_table_2": DAI_TABLE_2,
    }


def markdown(res: dict) -> str:
    """The table of docs/tracking.md: one line per sensor, sampling, fault and system."""
    head = ("| sensor | sampling | ADS-B | system | RMSE east m | RMSE north m | RMSE height m | false RA | leak RA "
            "| false TA | leak TA |\n|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
    lines = [head]
    for kind, by_s in res["rows"].items():
        for sampling, by_f in by_s.items():
            for fault, cell in by_f.items():
                for system in SYSTEMS:
                    if system in ("sensor",) and fault != "clean":
                        continue  # the sensor does not see ADS-B's fault: its line is the clean one
                    c = cell[system]
                    lines.append(f"| {kind} | {sampling} | {fault} | {system} | {c['rmse_east_m']} | {c['rmse_north_m']} "
                                 f"| {c['rmse_height_m']} | {c['false_ra']} | {c['leak_ra']} | {c['false_ta']} "
                                 f"| {c['leak_ta']} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.reports.fusion", description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=60, help="Monte Carlo runs (Dai: 60)")
    parser.add_argument("--seed", type=int, default=2017)
    parser.add_argument("--markdown", action="store_true", help="print the docs table instead of the JSON")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error("--runs must be >= 1")
    res = report(args.runs, args.seed)
    print(markdown(res) if args.markdown else json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
