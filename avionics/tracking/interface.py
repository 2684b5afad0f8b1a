"""What the core (avionics/pipeline/) and the node read and call of an intruder tracker: the Tracker protocol.

Implemented by the CV tracker (tracker.py) and the IMM tracker (imm_tracker.py), both under the shared lifecycle
(lifecycle.py); the composition root (avionics/compose.py `build_tracker`) builds one from the configuration.
States are the pipeline's [east, north, alt, v_east, v_north, v_up] in the tracking frame (avionics/base/frame.py).
"""

from __future__ import annotations

from typing import Mapping, Protocol, Sequence, runtime_checkable

import numpy as np

from avionics.base.types import IntruderKey, IntruderReport
from avionics.tracking.record import TrackRecord


@runtime_checkable
class Tracker(Protocol):
    tracks: Mapping[IntruderKey, TrackRecord]  # the published track of every intruder, read-only for callers

    def ingest_many(self, reports: list[IntruderReport], easts, norths) -> Sequence[bool]:
        """Apply a batch of reports (plane positions easts, norths); per report, whether it updated or started a
        published track."""
        ...

    def predict(self, keys: list[IntruderKey], t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """States (N, 6) and covariances (N, 6, 6) of the given tracks at t_s (nothing stored)."""
        ...

    def prune(self, now_s: float) -> list[IntruderKey]:
        """Delete the tracks silent for longer than delete_after_s; returns their keys."""
        ...

    def reframe(self, change) -> None:
        """The tangent plane moved (a base.frame.FrameChange): carry every filter into it."""
        ...

    def mode_infos(self, keys: list[IntruderKey], t_s: float | None = None) -> list[dict | None]:
        """Per track, the mode outputs of a multiple-model filter (None for a single-model one)."""
        ...

    def drop(self, key: IntruderKey) -> None:
        """Forget the intruder entirely (its tracks and filter storage): its next report starts a new track."""
        ...
