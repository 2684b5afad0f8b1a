"""One aircraft, one track: which track a report belongs to, whatever path it came by.

Tracks are keyed by (address, address source) (base/types.py IntruderKey). Two cases reach the same aircraft under
two keys or through two paths:

- **Several paths, one key.** The autopilot's receiver (ADSB_VEHICLE over MAVLink) and a ground feed (SBS, Beast,
  readsb JSON: io/feeds/) report the same 1090ES address: they share the key, so they update one track. Each report
  passes the tracker's own validation gate with its own source's accuracy (its NACp/NACv where the feed gives them,
  IntruderReport.position_sigma_m), so the gate is per source; what each path contributed is counted
  (`track.path.<path>.applied` / `.dropped`: dropped = outside the gate, out of order or a duplicate of a report
  another path already gave).
- **1090ES and UAT.** A 1090ES and a UAT address are different aircraft until shown otherwise: the two links have
  separate address spaces in practice (DO-282B 2.2.4.5.1.2 lets a UAT participant use a self-assigned temporary
  address), so the same 24 bits on both can be two aircraft. A report whose key has no track of its own, while its
  address has a track under the other source, joins that track only when its kinematics agree with the track's
  prediction at the report's time: d^2 = r^T S^-1 r over horizontal position (and velocity, and altitude in the
  same datum, when the report has them) within the chi-square quantile of tracking.gate_probability, S = H P H^T + R
  (the tracker's gate test, Radosavljevic eq 17). Agreement makes the key an alias of that track
  (`identity.fused`); disagreement leaves the report to start its own track (`identity.apart`). Every aliased report
  is tested again: one that disagrees ends the alias (`identity.split`) and goes to its own key, so two aircraft
  that share an address and happen to pass close to each other separate again as soon as they diverge.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np

from avionics.base.chi2 import chi2_quantile
from avionics.base.types import AddressSource, IntruderKey, IntruderReport

OTHER_SOURCE = {AddressSource.ES1090: AddressSource.UAT, AddressSource.UAT: AddressSource.ES1090}


def _other(key: IntruderKey) -> IntruderKey:
    """The same address under the other address source."""
    return IntruderKey(key.address, OTHER_SOURCE[key.source])


class IdentityResolver:
    """resolve(reports, tracker) -> the reports with a fused key where a 1090ES/UAT pair agrees; count(...) the
    per-path outcome of the tracker's gate."""

    def __init__(self, tracking_params, counters: Counter):
        self.config = tracking_params
        self.counters = counters
        self.aliases: set[IntruderKey] = set()  # keys whose reports join the other address source's track
        self._gate = [0.0] + [chi2_quantile(tracking_params.gate_probability, k) for k in range(1, 6)]

    def round_end(self, reports: list[IntruderReport], start: int, tracker) -> int:
        """Where the round of reports[start:] that can be resolved now ends: at the first report of a key without a
        track whose address an earlier report of the other source in this round is about to start a track for.
        That report waits for the next round, after the track exists, so that two links first heard in the same
        step still make one track (and the reports keep their arrival order)."""
        tracks = tracker.tracks
        starting: set[IntruderKey] = set()
        for i in range(start, len(reports)):
            key = reports[i].key
            if key in tracks or _other(key) in tracks:
                continue
            if _other(key) in starting and i > start:
                return i
            starting.add(key)
        return len(reports)

    def resolve(self, reports: list[IntruderReport], easts, norths, tracker) -> list[IntruderReport]:
        tracks = tracker.tracks
        # the joined track is gone (or the key has one of its own): the alias ends
        self.aliases -= {k for k in self.aliases if _other(k) not in tracks or k in tracks}
        out = reports
        for i, rep in enumerate(reports):
            if rep.key in tracks:
                continue  # its own track: the common case costs one look-up
            target = _other(rep.key)
            if target not in tracks:
                continue
            agrees = self._agrees(rep, easts[i], norths[i], target, tracker)
            if rep.key in self.aliases and not agrees:
                self.aliases.discard(rep.key)
                self.counters["identity.split"] += 1
            elif rep.key not in self.aliases:
                self.counters["identity.fused" if agrees else "identity.apart"] += 1
                if agrees:
                    self.aliases.add(rep.key)
            if agrees:
                if out is reports:
                    out = list(reports)
                out[i] = replace(rep, key=target)
        return out

    def _agrees(self, rep: IntruderReport, east: float, north: float, target: IntruderKey, tracker) -> bool:
        """The report is inside the chi-square gate of the target track's prediction at the report's time."""
        track = tracker.tracks[target]
        x, p = tracker.predict([target], max(rep.time_s, track.last_report_s))
        x, p = x[0], p[0]
        cfg = self.config
        pos_sigma = tracker.position_sigma_m(rep)
        index, value, variance = [0, 1], [east, north], [pos_sigma**2] * 2
        if rep.velocity_en_mps is not None:
            index += [3, 4]
            value += list(rep.velocity_en_mps)
            variance += [tracker.velocity_sigma_mps(rep) ** 2] * 2
        if rep.altitude_m is not None and rep.altitude_datum is track.datum and track.datum is not None:
            index.append(2)
            value.append(rep.altitude_m)
            variance.append(cfg.altitude_sigma_m**2)
        r = np.asarray(value) - x[index]
        s = p[np.ix_(index, index)] + np.diag(variance)
        try:
            d2 = float(r @ np.linalg.solve(s, r))
        except np.linalg.LinAlgError:
            return False
        return d2 <= self._gate[len(index)]

    def count(self, reports: list[IntruderReport], applied) -> None:
        """What each path's reports did at the tracker's gate."""
        for rep, ok in zip(reports, applied):
            self.counters[f"track.path.{rep.path}.{'applied' if ok else 'dropped'}"] += 1
