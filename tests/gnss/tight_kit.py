"""What the tight-filter tests share: a track's horizontal error against the reference."""

from __future__ import annotations

import numpy as np

from coopproc.model import Session
from coopproc.stages.gnss.tight_filter import TrackOutput


def track_errors(session: Session, out: TrackOutput) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seconds from the start, horizontal error, horizontal sigma of the tag's track
    (reference epochs only)."""
    t = np.asarray(out.time_s)
    x = np.asarray(out.state)
    ref = session.reference["tag"].interpolate_within(t)
    ok = np.isfinite(ref[:, 0])
    err = np.hypot(x[ok, 0] - ref[ok, 0], x[ok, 1] - ref[ok, 1])
    sig = np.hypot(*np.asarray(out.sigma)[ok, :2].T)
    return t[ok] - t[0], err, sig
