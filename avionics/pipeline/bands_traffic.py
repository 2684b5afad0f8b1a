"""The guidance bands' bookkeeping (a DO-365 alerter's; advisory/bands.py computes them): the traffic they are
computed against, kept from each assessment, and their once-a-second computation, as DAIDALUS is run at 1 Hz."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from avionics.base.types import IntruderKey
from avionics.pipeline.containment import Containment
from avionics.pipeline.records import NONE
from avionics.pipeline.schedule import AssessmentSchedule


class BandsTraffic:
    def __init__(self, engine, alert_names: Mapping[int, str], schedule: AssessmentSchedule, containment: Containment):
        """engine: advisory/bands.py BandsEngine, None: no bands (then nothing is kept)."""
        self.engine = engine
        self.alert_names = alert_names
        self.schedule = schedule
        self.containment = containment
        self._slot: int | None = None  # the second of the last bands computed
        # key -> (time, position, velocity, SUM errors (4,) or None, seen only by the ownship's sensors) of its last
        # assessment
        self._traffic: dict[IntruderKey, tuple] = {}

    def record(self, now_s: float, ev, own_alt_m: float) -> None:
        """An assessment's intruders (ev: their keys, predicted states xs, geometry, has_alt, encounter) at their
        datum-matched altitudes (own_alt_m: the ownship's), a coasted track's dead-reckoned (a lost threat stays in
        the bands while its alert is held); an intruder without an altitude leaves the traffic."""
        if self.engine is None:
            return
        keys, xs = ev.keys, ev.xs
        placed = ev.has_alt | ev.coasted  # an altitude known or dead-reckoned
        pos = np.column_stack([xs[:, :2], own_alt_m + ev.coasted_sz_m])
        errors = ev.encounter.uncertainty  # the SUM detector's inputs: the bands use them as the alerter does
        sensed = np.broadcast_to(np.asarray(ev.encounter.non_cooperative, bool), (len(keys),))
        for i in np.flatnonzero(placed):
            self._traffic[keys[i]] = (now_s, pos[i], xs[i, 3:6], None if errors is None else errors[i], bool(sensed[i]))
        for i in np.flatnonzero(~placed):
            self._traffic.pop(keys[i], None)

    def forget(self, key: IntruderKey) -> None:
        self._traffic.pop(key, None)

    def compute(self, now_s: float, ownship, states):
        """The guidance bands on the first assessment tick of each second: every intruder with an altitude
        re-assessed within the last period, at its datum-matched altitude (carried to now along its velocity when
        its slice came before this step), with its alert level (states: the advisory states). None: no bands in
        this step. A fault here is counted and logged; it never stops the advisories."""
        slot = math.floor(now_s + 1e-6)
        if self.engine is None or slot == self._slot:
            return None
        self._slot = slot
        try:
            own = ownship.state_at(now_s)
            if own is None:
                return None
            keys = sorted(k for k, (t, *_) in self._traffic.items() if self.schedule.recent(now_s, t))
            pos, vel, errors = np.empty((len(keys), 3)), np.empty((len(keys), 3)), np.zeros((len(keys), 4))
            sensed = np.zeros(len(keys), bool)
            stated = False
            for i, k in enumerate(keys):
                t, pos[i], vel[i], err, sensed[i] = self._traffic[k]
                pos[i] += vel[i] * (now_s - t)
                if err is not None:
                    errors[i], stated = err, True
            levels = [int(states.alert[r]) if (r := states.row(k)) is not None else NONE for k in keys]
            bands = self.engine.compute(now_s, own.x[:3], own.x[3:6], pos, vel, [str(k) for k in keys], levels,
                                        errors if stated else None, sensed)
            return replace(bands, intruders=tuple((str(k), lvl, self.alert_names[lvl]) for k, lvl in zip(keys, levels)))
        except Exception as exc:  # noqa: BLE001  (stage boundary: the bands)
            self.containment.bands_failed(now_s, exc)
            return None
