"""Is each platform's navigation in the session frame? A check on the range residuals.

``coopproc run`` takes every navigation file to be in the session's ENU frame. A
platform that navigates in its own shifted and rotated frame (the ``coopproc locate``
case: paper 004's target knows only its dead-reckoning increments) makes every output
nonsense. Its ranges say so: against the platforms whose positions are known in the
session frame (anchors, other platforms' navigation), the residuals

    v_i = range_i - |p(t_i) - q_i|

are large, and nearly vanish once the platform's track is moved by one 2-D rigid
transform (rotation about the vertical through its centroid + translation, fitted by
robust least squares). Dead-reckoning drift also shrinks under such a fit, but it is not
one rigid transform: fitted over the first and the second half of the ranges it gives
two different transforms, while a wrong frame gives the same one. A note fires when

- the residual RMS drops by more than :data:`MIN_GAIN` (3x),
- the transform is significant (rotation over :data:`MIN_ROTATION_DEG` or shift over
  :data:`MIN_SHIFT_RMS` x the residual RMS after the fit), and
- the two halves' transforms agree: applied to the track they differ, RMS, by less than
  :data:`MAX_HALF_SPLIT` of the full transform's own correction.

A platform in a wrong frame spoils its partners' residuals too, so they may fire as
well. The blame goes to the platform whose transform explains the most of the session's
squared residuals (it fixes the ranges to all its partners; each partner fixes only its
own pair); between two that explain as much (two platforms that only range each other),
to the one that is not a leader (leaders navigate with GNSS). A platform once named is
no longer used as a known partner, and the others are checked again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from coopproc.estimation.range_model import slant_ranges, slant_ranges_units
from coopproc.model import FloatArray, Session

__all__ = [
    "MAX_HALF_SPLIT",
    "MIN_GAIN",
    "MIN_ROTATION_DEG",
    "MIN_SHIFT_RMS",
    "FrameFit",
    "fit_frame",
    "frame_notes",
]

#: The residual RMS must drop by more than this factor.
MIN_GAIN = 3.0
#: A fitted rotation over this many degrees is significant...
MIN_ROTATION_DEG = 5.0
#: ...and so is a shift over this many times the residual RMS after the fit.
MIN_SHIFT_RMS = 3.0
#: The two halves' transforms must agree within this fraction of the full correction.
MAX_HALF_SPLIT = 0.35
#: Ranges used per platform at most (evenly subsampled), and at least.
MAX_RANGES = 2000
MIN_RANGES = 30
#: Ranges of a platform checked for usability at most (evenly subsampled; its usable count
#: is scaled from them): a day of 10 platforms has 760,000 per platform, and masking every
#: one of them was 2.3 s of the 4 s check (issue 11), for 2,000 used.
MAX_CANDIDATES = 50 * MAX_RANGES
#: Robust loss scale, m: residuals beyond it (NLOS, outliers) weigh as in an L1 fit.
_F_SCALE_M = 0.5
# The coarse search for the fit's starts: rotations, shifts per axis, ranges, starts kept.
_GRID_DEG = np.arange(0.0, 360.0, 15.0)
_GRID_STEPS = 21
_GRID_RANGES = 200
_GRID_REFINE = 8
_GRID_KEEP = 2


@dataclass(frozen=True)
class FrameFit:
    """The rigid transform that best explains one platform's range residuals."""

    platform: str
    #: Ranges used (at most MAX_RANGES), ranges usable (scaled from MAX_CANDIDATES evenly
    #: spaced ones when the platform has more), and the partners they go to.
    n: int
    n_usable: int
    partners: tuple[str, ...]
    rms_before_m: float
    rms_after_m: float
    #: Rotation about the vertical, degrees counter-clockwise (east towards north).
    rotation_deg: float
    #: Translation of the track's centroid, east and north, m.
    shift_en_m: tuple[float, float]
    #: RMS displacement of the track by the transform, m.
    correction_m: float
    #: RMS difference between the first and the second half's transforms on the track, m.
    half_split_m: float

    @property
    def shift_m(self) -> float:
        return float(np.hypot(*self.shift_en_m))

    @property
    def gain(self) -> float:
        return self.rms_before_m / max(self.rms_after_m, 1e-9)

    @property
    def explained_m2(self) -> float:
        """Sum of squared residuals the transform removes over the usable ranges, m^2."""
        return self.n_usable * (self.rms_before_m**2 - self.rms_after_m**2)

    @property
    def fires(self) -> bool:
        """A rigid transform explains the residuals: the navigation is in another frame."""
        significant = (
            abs(self.rotation_deg) > MIN_ROTATION_DEG
            or self.shift_m > MIN_SHIFT_RMS * self.rms_after_m
        )
        agree = self.half_split_m < MAX_HALF_SPLIT * self.correction_m
        return self.gain > MIN_GAIN and significant and agree


@dataclass(frozen=True)
class _Obs:
    time_s: FloatArray
    p: FloatArray  # (n, 3) the platform's navigation at the range times
    q: FloatArray  # (n, 3) the partner's position
    range_m: FloatArray
    partners: tuple[str, ...]
    n_usable: int


def _known_position(session: Session, pid: str, t: FloatArray) -> FloatArray | None:
    """Position (n, 3) of platform ``pid`` at ``t`` in the session frame, NaN where unknown."""
    info = session.platforms.get(pid)
    if info is None:
        return None
    nav = session.nav.get(pid)
    if info.role == "anchor":
        if info.position_enu_m is not None:
            return np.tile(np.asarray(info.position_enu_m, dtype=np.float64), (t.size, 1))
        if nav is not None and len(nav):
            return np.tile(nav.enu_m.mean(axis=0), (t.size, 1))
        return None
    if nav is None or len(nav) < 2:
        return None
    return nav.interpolate_within(t)


def _known_mask(session: Session, pid: str, t: FloatArray) -> NDArray[np.bool_]:
    """Where :func:`_known_position` gives a finite position, without interpolating."""
    info = session.platforms.get(pid)
    nav = session.nav.get(pid)
    if info is None or info.role == "anchor" or nav is None or len(nav) < 2:
        pos = _known_position(session, pid, t[:1])
        finite = pos is not None and bool(np.isfinite(pos).all())
        return np.full(t.shape[0], finite)
    if not np.isfinite(nav.enu_m).all():
        return np.asarray(np.isfinite(nav.interpolate_within(t)).all(axis=1))
    return nav.covered(t)


def _observations(session: Session, pid: str, known: set[str]) -> _Obs | None:
    nav = session.nav.get(pid)
    if nav is None or len(nav) < 2:
        return None
    frame = session.ranges.frame
    rows = session.ranges.rows_of(pid)
    if rows.size < MIN_RANGES:
        return None
    n_rows = rows.size
    if n_rows > MAX_CANDIDATES:
        rows = rows[np.linspace(0, n_rows - 1, MAX_CANDIDATES).round().astype(np.int64)]
    ids, first, second = session.ranges.id_codes  # integer codes, no string compares
    own = int(np.searchsorted(ids, pid))
    other = np.where(first[rows] == own, second[rows], first[rows])
    t = frame["time"].to_numpy(dtype=np.float64)[rows]
    r = frame["range"].to_numpy(dtype=np.float64)[rows]
    # which ranges are usable first (masks), the positions only at the ones used
    partners_known = [(k, str(ids[k])) for k in np.unique(other) if str(ids[k]) in known]
    q_ok = np.zeros(t.shape[0], dtype=bool)
    for k, partner in partners_known:
        sel = other == k
        q_ok[sel] = _known_mask(session, partner, t[sel])
    p_ok = (
        nav.covered(t)
        if np.isfinite(nav.enu_m).all()
        else np.isfinite(nav.interpolate_within(t)).all(axis=1)
    )
    ok = p_ok & q_ok & np.isfinite(r)
    if ok.sum() < MIN_RANGES:
        return None
    idx = np.flatnonzero(ok)
    usable = int(idx.size) if n_rows == rows.size else round(idx.size * n_rows / rows.size)
    if idx.size > MAX_RANGES:
        idx = idx[np.linspace(0, idx.size - 1, MAX_RANGES).round().astype(np.int64)]
    t, other = t[idx], other[idx]
    p = nav.interpolate_within(t)
    q = np.full_like(p, np.nan)
    for k, partner in partners_known:
        sel = other == k
        if sel.any():
            pos = _known_position(session, partner, t[sel])
            assert pos is not None  # its ranges are usable
            q[sel] = pos
    partners = tuple(str(ids[k]) for k in np.unique(other))
    return _Obs(t, p, q, r[idx], partners, usable)


def _moved(x: FloatArray, p: FloatArray, centre: FloatArray) -> FloatArray:
    """``p`` rotated by x[0] rad about the vertical through ``centre``, shifted by x[1:3]."""
    c, s = np.cos(x[0]), np.sin(x[0])
    d = p[:, :2] - centre
    out = p.copy()
    out[:, 0] = centre[0] + c * d[:, 0] - s * d[:, 1] + x[1]
    out[:, 1] = centre[1] + s * d[:, 0] + c * d[:, 1] + x[2]
    return out


def _residuals(x: FloatArray, obs: _Obs, centre: FloatArray) -> FloatArray:
    moved = _moved(x, obs.p, centre)
    return np.asarray(obs.range_m - slant_ranges(moved - obs.q), dtype=np.float64)


def _jacobian(x: FloatArray, obs: _Obs, centre: FloatArray) -> FloatArray:
    """d residual / d (rotation, shift east, shift north), (n, 3)."""
    c, s = np.cos(x[0]), np.sin(x[0])
    d = obs.p[:, :2] - centre
    _, unit = slant_ranges_units(_moved(x, obs.p, centre) - obs.q)
    turn = np.column_stack([-s * d[:, 0] - c * d[:, 1], c * d[:, 0] - s * d[:, 1]])
    jac = np.empty((d.shape[0], 3))  # the range model's unit vector through the move
    jac[:, 0] = -np.sum(unit[:, :2] * turn, axis=1)
    jac[:, 1] = -unit[:, 0]
    jac[:, 2] = -unit[:, 1]
    return jac


def _fit(obs: _Obs, centre: FloatArray, starts: list[FloatArray]) -> FloatArray:
    best, cost = starts[0], np.inf
    for x0 in starts:
        sol = least_squares(
            _residuals,
            x0,
            jac=_jacobian,  # type: ignore[arg-type]
            args=(obs, centre),
            loss="soft_l1",
            f_scale=_F_SCALE_M,
        )
        if sol.cost < cost:
            best, cost = sol.x, float(sol.cost)
    return np.asarray(best, dtype=np.float64)


def _grid_starts(obs: _Obs, centre: FloatArray) -> list[FloatArray]:
    """Starts for the fit: no transform, and the best few of a coarse search over every
    rotation, so that a frame rotated by any angle and shifted by up to the ranges'
    length is found. Per rotation of a grid, the shift of a grid with the smallest mean
    absolute residual (on a subsample) is refined by a fit on that subsample."""
    take = np.linspace(0, obs.time_s.size - 1, min(obs.time_s.size, _GRID_RANGES))
    sub = _take(obs, take.round().astype(np.int64))
    d = sub.p[:, :2] - centre
    dz2 = (sub.p[:, 2] - sub.q[:, 2]) ** 2
    # shifts that put the track's centroid within a range's length of the partners' centroid
    reach = float(np.median(sub.range_m)) + float(np.max(np.linalg.norm(d, axis=1)))
    axis = np.linspace(-reach, reach, _GRID_STEPS)
    base = sub.q[:, :2].mean(axis=0) - centre
    shifts = base + np.stack(np.meshgrid(axis, axis), axis=-1).reshape(-1, 2)  # (S, 2)
    coarse = []
    for theta in np.radians(_GRID_DEG):
        c, s = np.cos(theta), np.sin(theta)
        rotated = centre + np.column_stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]])
        east = rotated[None, :, 0] + shifts[:, None, 0] - sub.q[None, :, 0]
        north = rotated[None, :, 1] + shifts[:, None, 1] - sub.q[None, :, 1]
        rho = slant_ranges(np.stack([east, north], axis=-1), dz2)
        cost = np.mean(np.abs(sub.range_m - rho), axis=1)
        best = int(np.argmin(cost))
        coarse.append((float(cost[best]), np.array([theta, *shifts[best]])))
    coarse.sort(key=lambda item: item[0])
    refined = []
    for _, x0 in coarse[:_GRID_REFINE]:
        x = _fit(sub, centre, [x0])
        refined.append((float(np.mean(np.abs(_residuals(x, sub, centre)))), x))
    refined.sort(key=lambda item: item[0])
    return [np.zeros(3)] + [x for _, x in refined[:_GRID_KEEP]]


def _rms(v: FloatArray) -> float:
    return float(np.sqrt(np.mean(v * v)))


def _take(obs: _Obs, sel: np.ndarray) -> _Obs:
    return _Obs(
        obs.time_s[sel], obs.p[sel], obs.q[sel], obs.range_m[sel], obs.partners, int(sel.sum())
    )


def fit_frame(session: Session, pid: str, known: set[str] | None = None) -> FrameFit | None:
    """Fit a 2-D rigid transform to platform ``pid``'s navigation from its ranges to the
    platforms in ``known`` (default: every other platform); None with fewer than
    :data:`MIN_RANGES` usable ranges."""
    partners = set(session.platforms) - {pid} if known is None else known - {pid}
    obs = _observations(session, pid, partners)
    if obs is None:
        return None
    centre = obs.p[:, :2].mean(axis=0)
    zero = np.zeros(3)
    x = _fit(obs, centre, _grid_starts(obs, centre))
    half = obs.time_s <= np.median(obs.time_s)
    halves = [_fit(_take(obs, sel), centre, [x]) for sel in (half, ~half)]
    moved = _moved(x, obs.p, centre)
    split = _moved(halves[0], obs.p, centre) - _moved(halves[1], obs.p, centre)
    rotation = (np.degrees(x[0]) + 180.0) % 360.0 - 180.0
    return FrameFit(
        platform=pid,
        n=int(obs.time_s.size),
        n_usable=obs.n_usable,
        partners=obs.partners,
        rms_before_m=_rms(_residuals(zero, obs, centre)),
        rms_after_m=_rms(_residuals(x, obs, centre)),
        rotation_deg=float(rotation),
        shift_en_m=(float(x[1]), float(x[2])),
        correction_m=_rms(np.linalg.norm(moved[:, :2] - obs.p[:, :2], axis=1)),
        half_split_m=_rms(np.linalg.norm(split[:, :2], axis=1)),
    )


def _note(fit: FrameFit, session: Session) -> str:
    aux = ",".join(p for p in fit.partners if session.platforms[p].role != "anchor")
    hint = f" --aux {aux}" if aux else ""
    return (
        f"{fit.platform}'s navigation looks like it is in a frame of its own: its ranges "
        f"to {', '.join(fit.partners)} fit {fit.rms_after_m:.2f} m RMS instead of "
        f"{fit.rms_before_m:.2f} m once its track is rotated by {fit.rotation_deg:.1f} deg "
        f"and shifted by {fit.shift_m:.1f} m (east {fit.shift_en_m[0]:.1f}, north "
        f"{fit.shift_en_m[1]:.1f}, at its centroid), so the fused results are not "
        "meaningful; for a platform that knows only its own motion use "
        f"coopproc locate {session.root} --target {fit.platform}{hint}"
    )


def frame_notes(session: Session) -> list[str]:
    """One note per moving platform whose navigation a rigid transform explains (see the
    module docstring); empty when every platform's navigation fits the session frame."""
    known = set(session.platforms)
    candidates = [p for p in session.moving_platforms() if p in session.nav]
    notes = []
    while candidates:
        fits = [f for f in (fit_frame(session, p, known) for p in candidates) if f is not None]
        firing = [f for f in fits if f.fires]
        if not firing:
            break
        top = max(f.explained_m2 for f in firing)
        close = [f for f in firing if f.explained_m2 >= 0.9 * top]
        blamed = min(
            close,
            key=lambda f: (
                session.platforms[f.platform].role == "leader",
                -f.explained_m2,
                f.platform,
            ),
        )
        notes.append(_note(blamed, session))
        known.discard(blamed.platform)
        candidates.remove(blamed.platform)
    return notes
