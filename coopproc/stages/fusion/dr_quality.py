"""How good each platform's own dead reckoning is, measured against the cooperative solution.

The self-calibrated fusion of the observed ranges (:mod:`coopproc.stages.fusion.calibration`)
is the best estimate of where the platforms were that the session holds without a reference.
Its difference from a platform's own navigation, e(t) = nav(t) - fused(t), is that
navigation's error as far as the ranges can tell. Three figures summarize it:

- ``drift_mps``: the RMS per-axis rate of change of e over :data:`DRIFT_WINDOW_S` windows
  (the slope over 10 s rather than the 1 s change of DATA.md's ``drift_sigma``, so that the
  fused solution's own epoch-to-epoch noise does not count as drift);
- ``heading_drift_dpm``: the robust (Theil-Sen) slope, in deg/min, of the angle from the
  fused displacement to the platform's own displacement over :data:`HEADING_WINDOW_S`
  windows, counter-clockwise positive (a gyro bias makes it grow linearly);
- ``scale``: the median ratio of those displacements' lengths, minus 1 (odometer scale).

NaN where the platform did not travel enough (fewer than :data:`MIN_WINDOWS` windows of
:data:`MIN_TRAVEL_M` or more) or the session is too short. Measured on the dr-faults
scenario (seed 0): heading drift +2.89 deg/min against a true 3.0 (the simulator counts
clockwise), scale -2.83 / -1.78 / +2.27 % against -2.77 / -2.27 / +2.00 %. The figures
are reported next to the declared ``drift_sigma``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numba
import numpy as np

from coopproc.model import FloatArray, Session, Trajectory

__all__ = ["DeadReckoningQuality", "dead_reckoning_quality", "theil_sen_slope"]

DRIFT_WINDOW_S = 10.0
HEADING_WINDOW_S = 10.0
MIN_TRAVEL_M = 1.0
#: Heading drift and scale need this many moving windows (two minutes of travel): on the
#: 64 s TIERS session (slow robots, 1-3 cm/s velocity biases) fewer gave slopes of +-40
#: deg/min against a truth of +-2.5..5.
MIN_WINDOWS = 12


@dataclass(frozen=True)
class DeadReckoningQuality:
    """One platform's dead reckoning against the cooperative solution."""

    drift_mps: float
    heading_drift_dpm: float
    scale: float
    declared_drift_mps: float  # session.toml drift_sigma (NaN: none)
    #: a leader: the fusion takes its own fix, so its figures against the cooperative
    #: solution are ~0 whatever its navigation's error (not a measurement of it)
    leader: bool = False


def _resample(traj: Trajectory, step_s: float) -> tuple[FloatArray, FloatArray]:
    t = np.arange(traj.time_s[0], traj.time_s[-1], step_s)
    return t, traj.interpolate(t)


def _windows(t: FloatArray, width_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Start and end indices of back-to-back windows of ``width_s`` on a regular grid."""
    if t.shape[0] < 2:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    step = t[1] - t[0]
    n = max(round(width_s / step), 1)
    starts = np.arange(0, t.shape[0] - n, n)
    return starts, starts + n


def theil_sen_slope(y: FloatArray, x: FloatArray) -> float:
    """The median of the slopes (y_j - y_i) / (x_j - x_i) over every pair with x_j != x_i:
    ``scipy.stats.theilslopes(y, x)[0]`` bit for bit (the same differences and quotients,
    and the median of a set does not depend on its order), without its two n x n matrices
    and its full sort: a day of 10 s windows (8,640) took 6.9 s CPU and 1.9 GB per
    platform in theilslopes. Long series with ``x`` increasing (the windows in time
    order) are not stored whole: the median's order statistics are bracketed from a
    sample of the slopes, then one compiled pass counts the slopes below the bracket and
    keeps those inside it (:func:`_sampled_median`); otherwise one array of the
    n (n - 1) / 2 slopes."""
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    n = x.shape[0]
    increasing = n >= _SAMPLED_FROM and bool(np.all(x[1:] > x[:-1]))  # NaN: False
    if increasing and bool(np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        found = _sampled_median(y, x)
        if found is not None:
            return found
    slopes = np.empty(n * (n - 1) // 2)
    filled = 0
    for i in range(n - 1):
        dx = x[i + 1 :] - x[i]
        ok = (dx > 0) | (dx < 0)  # NaN and ties out, as theilslopes' deltax > 0
        # (y_i - y_j) / (x_i - x_j) == (y_j - y_i) / (x_j - x_i): negation is exact
        part = (y[i + 1 :][ok] - y[i]) / dx[ok]
        slopes[filled : filled + part.shape[0]] = part
        filled += part.shape[0]
    return float(np.median(slopes[:filled], overwrite_input=True))


#: Series at least this long take :func:`_sampled_median` (shorter: all slopes stored).
_SAMPLED_FROM = 600
_SAMPLE = 100_000


def _sampled_median(y: FloatArray, x: FloatArray) -> float | None:
    """``np.median`` of every slope (y_j - y_i) / (x_j - x_i), i < j, with ``x`` strictly
    increasing and everything finite, without storing them: the two middle order
    statistics lie in a bracket [a, b] taken from the sorted slopes of a random sample
    (+-4 standard deviations of the sample's rank); one pass counts the slopes below a
    and collects those in [a, b], and the median is taken there, as ``np.median`` takes
    it (the mean of the two middle values). None when the bracket missed (then the
    caller stores every slope)."""
    n = x.shape[0]
    total = n * (n - 1) // 2
    k_lo, k_hi = (total - 1) // 2, total // 2
    rng = np.random.default_rng(0)
    i = rng.integers(0, n, _SAMPLE)
    j = rng.integers(0, n, _SAMPLE)
    i, j = np.minimum(i, j), np.maximum(i, j)
    keep = i < j
    i, j = i[keep], j[keep]
    sample = np.sort((y[j] - y[i]) / (x[j] - x[i]))
    m = sample.shape[0]
    if m < 1000:
        return None
    margin = 4.0 * np.sqrt(m) + 10.0
    a = sample[max(int(m * k_lo / total - margin), 0)]
    b = sample[min(int(m * k_hi / total + margin), m - 1)]
    capacity = int(total * min(1.0, 2.0 * (2.0 * margin + 2.0) / m)) + 1024
    inside = np.empty(capacity)
    below, count = _count_and_collect(y, x, a, b, inside)
    if count >= capacity or not (below <= k_lo and k_hi < below + count):
        return None
    lo, hi = k_lo - below, k_hi - below
    part = np.partition(inside[:count], [lo, hi] if hi != lo else [lo])
    return float(np.mean(part[lo : hi + 1]))


@numba.njit(cache=True)
def _count_and_collect(
    y: FloatArray, x: FloatArray, a: float, b: float, inside: FloatArray
) -> tuple[int, int]:  # pragma: no cover - compiled
    """Slopes below ``a`` (counted) and in ``[a, b]`` (counted, and kept in ``inside``,
    valid while the count stays below its length), over every pair i < j, computed as
    numpy computes them."""
    below = 0
    count = 0
    last = inside.shape[0] - 1  # the caller checks that count < len(inside)
    n = x.shape[0]
    row = np.empty(n)
    for i in range(n - 1):
        yi = y[i]
        xi = x[i]
        width = n - i - 1
        for j in range(width):  # vectorized: the divisions of the row first
            row[j] = (y[i + 1 + j] - yi) / (x[i + 1 + j] - xi)
        for j in range(width):  # branch-free: the last cell takes the overflow
            s = row[j]
            below += s < a
            inside[min(count, last)] = s
            count += (s >= a) & (s <= b)
    return below, count


def _platform(nav: Trajectory, fused: Trajectory) -> tuple[float, float, float]:
    if len(fused) < 2:
        return float("nan"), float("nan"), float("nan")
    t, fused_xy = _resample(fused, 1.0)
    nav_xy = nav.interpolate(t)
    ok = np.all(np.isfinite(nav_xy[:, :2]), axis=1) & np.all(np.isfinite(fused_xy[:, :2]), axis=1)
    t, fused_xy, nav_xy = t[ok], fused_xy[ok, :2], nav_xy[ok, :2]
    err = nav_xy - fused_xy
    lo, hi = _windows(t, DRIFT_WINDOW_S)
    drift = float("nan")
    if lo.shape[0] >= 3:
        rate = (err[hi] - err[lo]) / (t[hi] - t[lo])[:, None]
        drift = float(np.sqrt(np.mean(rate * rate)))
    lo, hi = _windows(t, HEADING_WINDOW_S)
    d_nav = nav_xy[hi] - nav_xy[lo]
    d_fused = fused_xy[hi] - fused_xy[lo]
    length = np.hypot(d_fused[:, 0], d_fused[:, 1])
    moving = length >= MIN_TRAVEL_M
    heading = scale = float("nan")
    if np.count_nonzero(moving) >= MIN_WINDOWS:
        angle = np.degrees(
            np.arctan2(d_nav[:, 1], d_nav[:, 0]) - np.arctan2(d_fused[:, 1], d_fused[:, 0])
        )
        angle = (angle + 180.0) % 360.0 - 180.0
        mid = 0.5 * (t[lo] + t[hi])[moving] / 60.0
        # Theil-Sen: a window whose angle a velocity bias or a short turn spoiled does
        # not tilt the slope
        heading = theil_sen_slope(np.unwrap(angle[moving], period=360.0), mid)
        ratio = np.hypot(d_nav[:, 0], d_nav[:, 1])[moving] / length[moving]
        scale = float(np.median(ratio) - 1.0)
    return drift, heading, scale


def dead_reckoning_quality(
    session: Session, fused: Mapping[str, Trajectory]
) -> dict[str, DeadReckoningQuality]:
    """Per moving platform with navigation and a fused trajectory (module docstring)."""
    out = {}
    for platform in session.moving_platforms():
        nav = session.nav.get(platform)
        solution = fused.get(platform)
        if nav is None or solution is None or len(nav) < 2:
            continue
        drift, heading, scale = _platform(nav, solution)
        declared = session.platforms[platform].drift_sigma_mps
        out[platform] = DeadReckoningQuality(
            drift_mps=drift,
            heading_drift_dpm=heading,
            scale=scale,
            declared_drift_mps=float("nan") if declared is None else float(declared),
            leader=session.platforms[platform].role == "leader",
        )
    return out
