"""Declared dead-reckoning drifts checked against the data, not only used.

A follower's ``drift_sigma`` (session.toml) is the DI variance of the ranging stage
(paper 000 eq. (7)) and, with ``[fusion] state = "position"``, the fusion's process
noise. A wrong figure costs accuracy silently: declared 240 x too large on
``sample_logs``' A (1.032 m/s against 0.0043), the ranging stage finds A's DI "too poor
to smooth" on every pair and A's fused DI mean error is 0.105 m against 0.020 m.

The observed fusion measures each follower's drift (:mod:`~coopproc.stages.fusion.dr_quality`,
the RMS rate of change of its navigation's error against the cooperative solution over
10 s windows). Where the declared figure and that estimate differ by more than
:data:`DECLARED_FACTOR`, either way, the estimate replaces the declared figure for the
rest of the run (the ranging stage and the fusions of the processed ranges; the observed
fusion is run again when its model uses the figure), with one note saying both, unless
``[calibration] trust_declared = true`` (then the note says it was kept).

Why 10: the two figures measure the drift over different spans. The declared figure is
the 1-s change of the error (DATA.md, the real sessions' READMEs, the simulator's
``dr_drift_sigma_mps``), the estimate its 10-s slope: a navigation error that is all white
noise of sigma s has a 1-s figure sqrt(2) s and a 10-s figure sqrt(2) s / 10, a factor 10
apart with nothing wrong. Measured (declared / estimated): ``sample_logs`` A 1.7, C 1.5;
real ``tiers`` tb3 3.2, tb4 0.80, tb5 1.9, tb6 1.25, tb7 1.5; ``miluv1`` 2.9; ``plaza2``
1.1; ``tuc`` not measured (30 s); all kept. Replaced: ``dr-faults``' A, whose 3 deg/min
heading drift is not declared (0.0043 against 0.090, 1 / 21), and A declared 240 x too
large (1 / 413). Leaders are not checked: the fusion takes their own fix, so their
navigation's error against the cooperative solution is ~0 whatever it is.

The estimate is measured over the recording's first :data:`CHECK_SPAN_S` (ten minutes), not
the whole of it. The declared figure is the hardware's, the same at every length, while a
follower's heading error accumulates: over a whole day of the simulator's `large` scenario
(followers 50-60 deg off by the end, which the fusion's DR states model) the 10-s rate was
0.15-0.23 m/s against the declared 0.0043, the figure was replaced for the whole run from
the first minute, every DI window went ranges-only and DI found 71 of 500 events; with the
declared figure kept, 476 (docs/methods-ranging.md#cp-state). A recording up to ten minutes
is checked whole; beyond, the answer no longer changes with its length, so a 15-minute
recording and the first 15 minutes of its 2-hour continuation are judged alike (issue
30.1). Why ten minutes: 60 windows of 10 s, whose RMS rate has a relative standard error
of about 1 / sqrt(2 x 60) = 9 %, far inside the factor :data:`DECLARED_FACTOR` the check
allows; the contradictions it exists for are 21 x and 413 x (above). It was the first hour
before (2026-12-07): every session here shorter than an hour was checked whole either way
and no decision changed (`sample_logs`, the real sessions, the simulations).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from coopproc.model import Session, Trajectory
from coopproc.stages.fusion.dr_quality import DeadReckoningQuality, dead_reckoning_quality

__all__ = [
    "CHECK_SPAN_S",
    "DECLARED_FACTOR",
    "DeclaredDrifts",
    "check_declared_drifts",
    "check_drifts",
    "declared_quality",
    "first_span",
    "with_drifts",
]

#: A declared figure this many times the estimate, or less than its 1 / this, is
#: contradicted by the data (module docstring).
DECLARED_FACTOR = 10.0

#: The estimate is measured over the recording's first this many seconds (module
#: docstring: the answer must not depend on how long the recording goes on).
CHECK_SPAN_S = 600.0


def first_span(fused: Mapping[str, Trajectory], span_s: float) -> dict[str, Trajectory]:
    """Each trajectory up to ``span_s`` after the earliest first epoch of all of them."""
    starts = [float(t.time_s[0]) for t in fused.values() if len(t)]
    if not starts:
        return dict(fused)
    end = min(starts) + span_s
    out = {}
    for pid, traj in fused.items():
        keep = traj.time_s <= end
        if keep.all():
            out[pid] = traj
            continue
        cut = {
            f.name: getattr(traj, f.name)[keep]
            for f in dataclasses.fields(traj)
            if isinstance(getattr(traj, f.name), np.ndarray)
        }
        out[pid] = dataclasses.replace(traj, **cut)
    return out


@dataclass(frozen=True)
class DeclaredDrifts:
    """The drifts the data contradict: platform -> (declared, estimated), m/s."""

    contradicted: Mapping[str, tuple[float, float]]
    #: the estimates replace the declared figures (False: ``trust_declared``)
    replaced: bool
    notes: tuple[str, ...]


def check_declared_drifts(
    session: Session, quality: Mapping[str, DeadReckoningQuality]
) -> DeclaredDrifts:
    """The followers whose declared ``drift_sigma`` the estimate contradicts by more than
    :data:`DECLARED_FACTOR`, with one note each (module docstring)."""
    trust = session.config.trust_declared
    contradicted: dict[str, tuple[float, float]] = {}
    notes = []
    for platform, q in sorted(quality.items()):
        info = session.platforms.get(platform)
        declared, estimate = q.declared_drift_mps, q.drift_mps
        if info is None or info.role != "follower":
            continue
        if not (math.isfinite(declared) and declared > 0):
            continue
        if not (math.isfinite(estimate) and estimate > 0):
            continue
        ratio = declared / estimate
        if 1.0 / DECLARED_FACTOR <= ratio <= DECLARED_FACTOR:
            continue
        contradicted[platform] = (declared, estimate)
        how = f"{ratio:.1f} x" if ratio > 1.0 else f"1 / {1.0 / ratio:.1f} of"
        said = (
            f"{platform}'s declared drift_sigma {declared:.4f} m/s is {how} what its "
            f"navigation drifts against the cooperative solution ({estimate:.4f} m/s; "
            f"contradicted beyond {DECLARED_FACTOR:g} x)"
        )
        if trust:
            notes.append(f"{said}: kept as declared ([calibration] trust_declared = true)")
        else:
            notes.append(
                f"{said}: {estimate:.4f} m/s used instead ([calibration] trust_declared = "
                "true keeps the declared figure)"
            )
    return DeclaredDrifts(contradicted, bool(contradicted) and not trust, tuple(notes))


def with_drifts(session: Session, drifts: Mapping[str, float]) -> Session:
    """``session`` with the ``drift_sigma`` of the platforms in ``drifts`` replaced (the
    session itself when there are none)."""
    if not drifts:
        return session
    platforms = {
        pid: dataclasses.replace(p, drift_sigma_mps=drifts[pid]) if pid in drifts else p
        for pid, p in session.platforms.items()
    }
    return dataclasses.replace(session, platforms=platforms)


def declared_quality(
    quality: Mapping[str, DeadReckoningQuality], declared: Mapping[str, tuple[float, float]]
) -> dict[str, DeadReckoningQuality]:
    """``quality`` with the declared figure of the ``declared`` platforms as declared
    (a session with the estimates in its place says the estimate)."""
    return {
        p: dataclasses.replace(q, declared_drift_mps=declared[p][0]) if p in declared else q
        for p, q in quality.items()
    }


def check_drifts(
    session: Session, dr_session: Session, fused: Mapping[str, Trajectory], params: Any
) -> tuple[DeclaredDrifts, Session, Session, bool]:
    """The check of ``session``'s declared drifts against the cooperative solution
    ``fused``, the session and the session without tags (``dr_session``) with the
    estimates in place where they replace the declared figures, and whether the fusion
    with ``params`` used one of the replaced figures (``state = "position"``: its
    followers' process noise; with DR states it does not)."""
    first = first_span(fused, CHECK_SPAN_S)
    checked = check_declared_drifts(session, dead_reckoning_quality(session, first))
    if not checked.replaced:
        return checked, session, dr_session, False
    drifts = {p: estimate for p, (_, estimate) in checked.contradicted.items()}
    new = with_drifts(session, drifts)
    new_dr = new if dr_session is session else with_drifts(dr_session, drifts)
    return checked, new, new_dr, getattr(params, "state", "dr") != "dr"
