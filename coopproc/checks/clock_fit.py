"""The numerics of the clock-offset estimate (:mod:`coopproc.checks.clock`).

A platform whose navigation clock runs ``tau`` seconds ahead of the range clock gives,
for every range of a pair (a, b) measured at range time t,

    L(t) = | P_a(t + tau_a) - P_b(t + tau_b) | + bias + noise                      (1)

where P is the navigation as recorded (anchors: their fixed position, tau = 0). Three
steps estimate every tau:

1. **Common offset, coarse** (:func:`common_lag`): all navigation against the ranges
   with one offset (a range clock in UTC against navigation in GPS time): the
   normalized cross-correlation of the range rate L' with the navigation's distance
   rate d' over every lag the data spans (FFT, pooled over the pairs; eq. (2)),

       rho(k) = sum x(t) y(t + k) / sqrt(sum x(t)^2 m_y(t + k) * sum m_x(t) y(t + k)^2)   (2)

   with x = L', y = d', m the masks of valid samples. Up to 15 hours each way (whole-hour
   time zones) where the overlap is at least :data:`MIN_OVERLAP_FRACTION` of the ranges.
2. **One platform, coarse** (:func:`platform_lag`): each platform's offset alone, the
   others held, on a grid of 0.5 s over +-60 s around the common offset and around 0
   (and whole hours), scored by (2) over its pairs in the most dynamic window of
   :data:`WINDOW_S`.
3. **Refinement** (:func:`refine`): Gauss-Newton on (1) for every tau at once, with a
   bias per pair and :data:`block_s` block (a dead-reckoning drift is a slowly changing
   bias: the blocks take it out, the offset is measured from the distance changes within
   them), Huber weights (NLOS), and the 1-sigma from the residuals and the slope,
   inflated for correlated residuals by the effective-sample-size factor
   1 + 2 sum_k rho_k (rho_k the residuals' autocorrelation at lag k, :func:`_ess_factor`).

The Jacobian of (1) uses a velocity differenced over +-:data:`VELOCITY_HALF_S`, not the
slope between the two navigation epochs that the interpolation uses: with that slope the
navigation's noise enters both the residual and its derivative and biases the offset
(a 2 cm jitter at 10 Hz moves a 50 ms estimate by tens of milliseconds, the bias
trajectopy shows), with the wider difference the two are independent.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from coopproc.estimation.range_model import slant_ranges
from coopproc.model import FloatArray, Trajectory

__all__ = [
    "MIN_OVERLAP_FRACTION",
    "NEAR_LAG_S",
    "PEAK_STEP_S",
    "SEARCH_STEP_S",
    "VELOCITY_HALF_S",
    "WINDOW_S",
    "PairData",
    "Positions",
    "common_lag",
    "grid_step",
    "lag_correlation",
    "platform_lag",
    "velocity",
]

#: Half-width of the velocity difference of the Jacobian, s (see the module docstring).
VELOCITY_HALF_S = 0.5
#: Half-width of the rate difference of the coarse series, s: a range's noise (8-15 cm)
#: over 1 s is a rate noise larger than the platforms' 0.1-1 m/s; over +-1 s it is halved.
RATE_HALF_S = 1.0
#: Window of the one-platform search (2), s.
WINDOW_S = 600.0
#: Smallest overlap of a lag of (2), as a fraction of the ranges' samples, and in s.
MIN_OVERLAP_FRACTION = 0.5
MIN_OVERLAP_S = 30.0
#: A lag nearer 0 is kept when its correlation is within this fraction of the best one.
PEAK_MARGIN = 0.05
#: Lags searched by (2): 15 h each way (the widest time zone, UTC+14, and its margin).
MAX_LAG_S = 15 * 3600.0
#: One-platform search: +-60 s (the 18 s leap seconds, a minute of margin) in steps of
#: 1 s (the rate differences over +-1 s make the correlation peak 2-3 s wide), then
#: +-1.5 s in steps of 0.25 s around the best; on a grid of 0.5 s.
NEAR_LAG_S = 60.0
SEARCH_STEP_S = 1.0
PEAK_STEP_S = 0.25
FINE_STEP_S = 0.5
Positions = Callable[[FloatArray], FloatArray]


def grid_step(span_s: float) -> float:
    """The coarse grid step for a span: 0.5 s, coarser beyond 2^16 samples (a day: 1.3 s)."""
    return max(FINE_STEP_S, span_s / 65536.0)


@dataclass(frozen=True, eq=False)
class PairData:
    """The ranges of one pair whose two ends have positions (navigation or anchor)."""

    a: str
    b: str
    time_s: FloatArray
    range_m: FloatArray


def velocity(traj: Trajectory, time_s: FloatArray, half_s: float = VELOCITY_HALF_S) -> FloatArray:
    """(n, 3) velocity at ``time_s`` differenced over +-``half_s`` (clamped to the span)."""
    t0, t1 = traj.span_s
    lo = np.clip(time_s - half_s, t0, t1)
    hi = np.clip(time_s + half_s, t0, t1)
    step = np.maximum(hi - lo, 1e-9)
    return (traj.interpolate(hi) - traj.interpolate(lo)) / step[:, None]


def _on_grid(t: FloatArray, y: FloatArray, grid: FloatArray, max_gap_s: float) -> FloatArray:
    """``y(t)`` linearly interpolated at ``grid``; NaN outside ``t`` and across gaps."""
    out = np.interp(grid, t, y)
    if t.shape[0] < 2:
        return np.full(grid.shape[0], np.nan)
    right = np.clip(np.searchsorted(t, grid), 1, t.shape[0] - 1)
    gap = (t[right] - t[right - 1]) > max_gap_s
    out[gap | (grid < t[0]) | (grid > t[-1])] = np.nan
    return out


def _rate(y: FloatArray, step_s: float) -> FloatArray:
    """Central difference over +-:data:`RATE_HALF_S` along the last axis (NaN at the ends)."""
    m = max(1, round(RATE_HALF_S / step_s))
    out = np.full(y.shape, np.nan)
    out[..., m:-m] = (y[..., 2 * m :] - y[..., : -2 * m]) / (2 * m * step_s)
    return out


def _gap_of(t: FloatArray) -> float:
    """Gap limit of a range series: 3 x its median interval, at least 3 s."""
    return max(3.0, 3.0 * float(np.median(np.diff(t)))) if t.shape[0] > 1 else 3.0


def _nav_grid(
    positions: Mapping[str, Trajectory | FloatArray], pid: str, grid: FloatArray
) -> FloatArray:
    p = positions[pid]
    if isinstance(p, Trajectory):
        return np.column_stack(
            [_on_grid(p.time_s, p.enu_m[:, i], grid, p.gap_limit_s()) for i in range(3)]
        )
    return np.broadcast_to(np.asarray(p, dtype=np.float64), (grid.shape[0], 3))


@dataclass(frozen=True)
class LagPeak:
    """The best lag of (2): its value, correlation and overlap (samples)."""

    lag_s: float
    rho: float
    overlap: int


def lag_correlation(
    xs: Sequence[FloatArray], ys: Sequence[FloatArray], step_s: float, complex_: bool = False
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(lags s, rho, overlap) of eq. (2) pooled over the series pairs (x_i, y_i).

    Every series is on one grid of ``step_s``; NaN marks a missing sample. With
    ``complex_`` the series are complex (east + i north velocity) and rho is the modulus
    of the complex correlation: blind to a rotation of one frame.
    """
    n = xs[0].shape[0]
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    fft, ifft = (np.fft.fft, np.fft.ifft) if complex_ else (np.fft.rfft, np.fft.irfft)
    sums: list[NDArray[np.complex128]] = []
    for x, y in zip(xs, ys, strict=True):
        mx, my = np.isfinite(x).astype(np.float64), np.isfinite(y).astype(np.float64)
        x0, y0 = np.where(mx > 0, x, 0), np.where(my > 0, y, 0)
        fx, fy = fft(x0, nfft), fft(y0, nfft)
        fmx, fmy = fft(mx, nfft), fft(my, nfft)
        fx2, fy2 = fft(np.abs(x0) ** 2, nfft), fft(np.abs(y0) ** 2, nfft)
        terms = [np.conj(fx) * fy, np.conj(fx2) * fmy, np.conj(fmx) * fy2, np.conj(fmx) * fmy]
        sums = terms if not sums else [s + t for s, t in zip(sums, terms, strict=True)]
    back = [ifft(v, nfft) for v in sums]
    lags = np.arange(-(n - 1), n)
    idx = lags % nfft
    c, dx, dy, k = (v[idx] for v in back)
    rho = np.abs(c) / np.sqrt(np.maximum(np.real(dx) * np.real(dy), 1e-300))
    return lags * step_s, rho.astype(np.float64), np.rint(np.real(k)).astype(np.float64)


def _best(
    lags: FloatArray, rho: FloatArray, overlap: FloatArray, step_s: float, series: int = 1
) -> LagPeak | None:
    """The highest rho among the lags with enough overlap (``overlap`` summed over
    ``series`` series: :data:`MIN_OVERLAP_S` each), parabola-interpolated."""
    need = max(
        series * MIN_OVERLAP_S / step_s, MIN_OVERLAP_FRACTION * float(overlap.max(initial=0))
    )
    ok = (overlap >= need) & (np.abs(lags) <= MAX_LAG_S) & np.isfinite(rho)
    if not ok.any():
        return None
    i = _nearest_good(lags, np.where(ok, rho, -np.inf))
    lag = float(lags[i])
    if 0 < i < lags.shape[0] - 1 and ok[i - 1] and ok[i + 1]:
        y0, y1, y2 = rho[i - 1], rho[i], rho[i + 1]
        den = y0 - 2 * y1 + y2
        if den < 0:
            lag += 0.5 * float(y0 - y2) / float(den) * (lags[1] - lags[0])
    return LagPeak(lag, float(rho[i]), int(overlap[i]))


def common_lag(
    pairs: Sequence[PairData], positions: Mapping[str, Trajectory | FloatArray]
) -> LagPeak | None:
    """Step 1: the one offset of every navigation against the ranges, eq. (2)."""
    if not pairs:
        return None
    spans = [(p.time_s[0], p.time_s[-1]) for p in pairs]
    spans += [v.span_s for v in positions.values() if isinstance(v, Trajectory) and len(v)]
    lo, hi = min(s[0] for s in spans), max(s[1] for s in spans)
    h = grid_step(hi - lo)
    grid = np.arange(lo, hi + h, h)
    cache: dict[str, FloatArray] = {}
    xs, ys = [], []
    for pair in pairs:
        for pid in (pair.a, pair.b):
            if pid not in cache:
                cache[pid] = _nav_grid(positions, pid, grid)
        d = slant_ranges(cache[pair.a] - cache[pair.b])
        xs.append(_rate(_on_grid(pair.time_s, pair.range_m, grid, _gap_of(pair.time_s)), h))
        ys.append(_rate(d, h))
    return _best(*lag_correlation(xs, ys, h), h, len(xs))


def platform_lag(
    pid: str,
    pairs: Sequence[PairData],
    positions: Mapping[str, Trajectory | FloatArray],
    offsets: Mapping[str, float],
    candidates_s: FloatArray,
) -> LagPeak | None:
    """Step 2: the offset of ``pid``'s navigation, the others at ``offsets``, eq. (2)."""
    mine = [p for p in pairs if pid in (p.a, p.b)]
    traj = positions[pid]
    if not mine or not isinstance(traj, Trajectory):
        return None
    h = FINE_STEP_S
    t_all = np.concatenate([p.time_s for p in mine])
    lo, hi = float(t_all.min()), float(t_all.max())
    start = _busiest(t_all, lo, hi)
    grid = np.arange(start, min(hi, start + WINDOW_S) + h, h)
    num = np.zeros(candidates_s.shape[0])
    den_x, den_y, cnt = num.copy(), num.copy(), num.copy()
    shifted = np.stack(
        [_on_grid(traj.time_s, traj.enu_m[:, i], (grid[None, :] + candidates_s[:, None]).ravel(),
                  traj.gap_limit_s()).reshape(candidates_s.shape[0], grid.shape[0])
         for i in range(3)],
        axis=-1,
    )  # fmt: skip
    for pair in mine:
        other = pair.b if pair.a == pid else pair.a
        q = positions[other]
        if isinstance(q, Trajectory):
            pq = _nav_grid({other: q}, other, grid + offsets.get(other, 0.0))
        else:
            pq = _nav_grid(positions, other, grid)
        x = _rate(_on_grid(pair.time_s, pair.range_m, grid, _gap_of(pair.time_s)), h)
        y = _rate(slant_ranges(shifted - pq[None, :, :]), h)
        mx, my = np.isfinite(x), np.isfinite(y)
        both = mx[None, :] & my
        xv, yv = np.where(mx, x, 0.0)[None, :], np.where(my, y, 0.0)
        num += np.sum(np.where(both, xv * yv, 0.0), axis=1)
        den_x += np.sum(np.where(both, xv**2, 0.0), axis=1)
        den_y += np.sum(np.where(both, yv**2, 0.0), axis=1)
        cnt += both.sum(axis=1)
    rho = num / np.sqrt(np.maximum(den_x * den_y, 1e-300))
    order = np.argsort(candidates_s)
    return _best_unordered(candidates_s[order], rho[order], cnt[order], h, len(mine))


def _best_unordered(
    lags: FloatArray, rho: FloatArray, cnt: FloatArray, h: float, series: int
) -> LagPeak | None:
    """:func:`_best` on sorted but unevenly spaced lags (parabola only between neighbours
    one step apart)."""
    need = max(series * MIN_OVERLAP_S / h, MIN_OVERLAP_FRACTION * float(cnt.max(initial=0)))
    ok = (cnt >= need) & np.isfinite(rho)
    if not ok.any():
        return None
    i = _nearest_good(lags, np.where(ok, rho, -np.inf))
    lag = float(lags[i])
    if 0 < i < lags.shape[0] - 1 and ok[i - 1] and ok[i + 1]:
        left, right = lags[i] - lags[i - 1], lags[i + 1] - lags[i]
        den = rho[i - 1] - 2 * rho[i] + rho[i + 1]
        if abs(left - h) < 1e-9 and abs(right - h) < 1e-9 and den < 0:
            lag += 0.5 * float(rho[i - 1] - rho[i + 1]) / float(den) * h
    return LagPeak(lag, float(rho[i]), int(cnt[i]))


def _nearest_good(lags: FloatArray, score: FloatArray) -> int:
    """The peak nearest 0 whose score is within :data:`PEAK_MARGIN` of the best: a platform
    driving loops correlates with itself one lap later nearly as well as at the true lag;
    the lap is never the likelier offset."""
    best = float(np.max(score))
    left = np.concatenate([[-np.inf], score[:-1]])
    right = np.concatenate([score[1:], [-np.inf]])
    peaks = (score >= left) & (score >= right) & (score >= best - PEAK_MARGIN * abs(best))
    good = np.flatnonzero(peaks)
    return int(good[np.argmin(np.abs(lags[good]))])


def _busiest(t: FloatArray, lo: float, hi: float) -> float:
    """Start of the :data:`WINDOW_S` window holding the most ranges."""
    if hi - lo <= WINDOW_S:
        return lo
    starts = np.arange(lo, hi - WINDOW_S, WINDOW_S / 8)
    s = np.sort(t)
    counts = np.searchsorted(s, starts + WINDOW_S) - np.searchsorted(s, starts)
    return float(starts[int(np.argmax(counts))])
