r"""Block bootstrap over time: confidence intervals and paired comparisons of the tables'
statistics without resampling a single epoch.

Errors along a trajectory are strongly autocorrelated (the TIERS range residuals' lag-1
correlation is 0.51-0.94, ``report --stochastic``), so an i.i.d. bootstrap (or a plain
``t`` interval) would be far too narrow. The circular block bootstrap (Politis & Romano
1992; the moving-block bootstrap of Kuensch 1989 with the series wrapped end to start, so
that every epoch is drawn equally often and a resample's mean is centred on the sample's)
draws ``k = ceil(n / b)`` blocks of ``b`` consecutive epochs (in time order, starts
uniform) and joins them into a resample of ``k b`` (about n) epochs, keeping the
correlation within each block.

**Block length** ``b``: the automatic choice of Politis & White (2004) with the
correction of Patton, Politis & White (2009), :func:`block_length` (flat-top lag window;
the formula of the ``arch`` package's ``optimal_block_length``, column ``circular``),
computed on the error series itself (``e_i`` of Table 2, ``h_i`` of Table 3; the longer
of the two in a paired comparison). That series' correlation is the longest of the
statistic's inputs (the squares of a Gaussian series have correlation rho^2). At least 1,
at most ``min(3 sqrt(n), n / 3)``. An AR(1) error with rho = 0.9 gets b = 40 at 600
epochs, 94 at 3600, 186 at 36 000.

**No epoch is resampled.** Every statistic of the tables is a function of sums over the
epochs (``sum e``, ``sum e^2``, ``sum r^2``, ``sum (d_{i+1} - d_i)^2``, a count): a
block's sum is the difference of two prefix sums, so a resample's sum is the sum of its k
block sums, ``(B, k)`` numbers instead of ``(B, n)``. With short blocks k is large (white
noise: b = 2, k = n / 2, and B k gathers took 3 s for the 135 range series of the
10-platform hour); beyond :data:`EXACT_BLOCKS` blocks a resample, the sum of k
independent draws of the n circular block sums is drawn from its normal law (mean
``k mu``, covariance ``k Sigma`` of the block sums, the central limit theorem over the k
draws): the resampled statistics' spread, all the intervals use, is unchanged, at
``O(n m + B m)`` instead of ``O(B n / b)``, unless the sum would be skewed (more than
:data:`MAX_SKEWNESS`: heavy-tailed block sums), when the blocks are drawn after all.

**Intervals** ``T +- t sd``: T the sample's statistic, sd the standard deviation of the
B = 1000 resampled statistics times ``sqrt(variance_ratio)``, t the Student quantile of
the level (``--ci``, default 0.95) at ``1.5 (n / b - 1)`` degrees of freedom. Two
corrections of the plain percentile interval, both measured: with rho = 0.9 at 600
epochs (30 independent-looking blocks) the percentile interval of a mean covered the
truth 84-87 % of 300 simulated series and a paired test of two equal RMSEs rejected at
5 % in 12-14 %; the block bootstrap under-estimates the variance of a mean by the
correlation beyond its blocks, :func:`variance_ratio` puts it back (Kuensch 1989's
Bartlett weights against the flat-top long-run variance), and the variance estimated
from about n / b blocks has those degrees of freedom (overlapping batch means, Meketon &
Schmeiser 1984). With both: 95 % coverage and 6 % false rejections at 600 epochs, 93 %
and 7 % at 3600, 95 % and 3 % for white noise. The **p-value** of a paired difference is
``2 P(t > |T| / sd)``, so the interval excludes zero exactly when ``p < 1 - level``.

The smoothness, a ratio of two sums of squares, gets its interval on the log scale,
``exp(log T +- t sd(log T*))``: never below 0 and as skewed as the ratio.

**Quantiles** (CEP50, CEP95, medians) are not sums: their intervals are Woodruff's
(1952): the bootstrap spread of ``F*(Q)``, the share of a resample's errors below the
sample quantile ``Q`` (a mean of indicators: a sum), gives the interval ``q +- t sd`` of
the share, mapped back through the sample's quantile function.

**Seeded**: each interval's generator is seeded from :data:`SEED` and the CRC-32 of the
names of what it resamples (pair or platform, methods), so the numbers do not depend on
the order or the set of the other rows, and a CSV is byte-identical run to run. Fewer
than :data:`MIN_EPOCHS` epochs give no interval (NaN).

The maximum (and minimum, and the largest |error|) has no interval: the bootstrap of an
extreme is inconsistent (Bickel & Freedman 1981), it never exceeds the sample's own.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import fft as sp_fft

from coopproc.distributions import t_ppf, t_sf
from coopproc.model import FloatArray

__all__ = [
    "DEFAULT_LEVEL",
    "DEFAULT_RESAMPLES",
    "EXACT_BLOCKS",
    "MIN_EPOCHS",
    "SEED",
    "Blocks",
    "block_length",
    "draw_blocks",
    "generator",
    "interval",
    "p_value",
    "quantile_interval",
    "resampled_sums",
    "spread",
    "variance_ratio",
]

#: Confidence level of the intervals (``--ci``).
DEFAULT_LEVEL = 0.95
#: Resamples per interval: the 2.5 % tail of 1000 draws holds 25 of them, which puts the
#: ends of a 95 % interval within about 3 % of their value at B = 10 000 (measured on the
#: paper-experiment session's RMSEs).
DEFAULT_RESAMPLES = 1000
#: Fewest epochs that get an interval (Politis & White's ACF test needs some lags).
MIN_EPOCHS = 20
#: Root seed of every generator (a fixed number: byte-identical CSVs).
SEED = 33_2026

IntArray = NDArray[np.int64]


def generator(*names: str) -> np.random.Generator:
    """A generator seeded from :data:`SEED` and the CRC-32 of ``names`` (what is resampled)."""
    return np.random.default_rng([SEED, *(zlib.crc32(n.encode()) for n in names)])


def _autocovariance(x: FloatArray, lags: int) -> FloatArray:
    """Autocovariance (divisor n) of the demeaned ``x`` at lags 0 .. ``lags`` (FFT)."""
    n = x.shape[0]
    y = x - np.mean(x)
    size = sp_fft.next_fast_len(n + lags + 1, real=True)  # no wrap-around up to ``lags``
    f = sp_fft.rfft(y, size)
    acv = sp_fft.irfft(f * np.conj(f), size)[: lags + 1] / n
    return np.asarray(acv, dtype=np.float64)


def _flat_top(x: FloatArray) -> tuple[int, FloatArray, int]:
    """Politis & White's lag-window choice for ``x``: (M, autocovariance to lag
    max(M, cap), cap = min(3 sqrt(n), n / 3))."""
    n = int(x.shape[0])
    cap = int(max(1.0, math.ceil(min(3.0 * math.sqrt(n), n / 3.0))))
    kn = max(5, int(math.log10(n)))
    m_max = min(math.ceil(math.sqrt(n)) + kn, n - 1)
    acv = _autocovariance(x, min(max(m_max, cap), n - 1))
    if not acv[0] > 0:
        return 0, acv, cap
    rho = np.abs(acv[: m_max + 1] / acv[0])
    bound = 2.0 * math.sqrt(math.log10(n) / n)
    small = rho[1:] < bound  # small[j]: lag j + 1
    # the first m with lags m+1 .. m+kn all small
    window = np.convolve(small.astype(np.int64), np.ones(kn, dtype=np.int64), "valid")
    hits = np.flatnonzero(window == kn)
    m = 2 * max(int(hits[0]), 1) if hits.size else m_max
    return min(m, m_max), acv, cap


def _window(m: int) -> tuple[FloatArray, FloatArray]:
    """Lags 1 .. m and the flat-top window at them (1 up to m / 2, then 2 (1 - k / m))."""
    k = np.arange(1, m + 1, dtype=np.float64)
    t = k / m
    return k, np.where(t <= 0.5, 1.0, 2.0 * (1.0 - t))


def block_length(x: FloatArray) -> int:
    """Politis & White's (2004) automatic block length for the circular block bootstrap
    (Patton, Politis & White 2009), rounded up, in ``1 .. min(3 sqrt(n), n / 3)``.

    ``m``: the first lag after which ``K_n = max(5, log10 n)`` consecutive
    autocorrelations are all below ``2 sqrt(log10(n) / n)``; ``M = min(2 m, sqrt(n) +
    K_n)``; with the flat-top window ``lambda(t)`` (1 up to 1/2, then ``2 (1 - t)``),
    ``G = sum_{|k|<=M} lambda(k/M) |k| R(k)``, ``g = sum_{|k|<=M} lambda(k/M) R(k)``,
    ``b = (2 G^2 / (4/3 g^2))^(1/3) n^(1/3)``. A constant or too short series gives 1.
    """
    x = np.asarray(x, dtype=np.float64)
    n = int(x.shape[0])
    if n < 4:
        return 1
    m, acv, cap = _flat_top(x)
    if m == 0:
        return 1
    k, lam = _window(m)
    g_big = float(np.sum(2.0 * lam * k * acv[1 : m + 1]))
    g_small = float(acv[0] + np.sum(2.0 * lam * acv[1 : m + 1]))
    if g_small <= 0 or g_big == 0:
        return 1
    b = (2.0 * g_big**2 / (4.0 / 3.0 * g_small**2)) ** (1.0 / 3.0) * n ** (1.0 / 3.0)
    return int(min(max(math.ceil(b), 1), cap))


def variance_ratio(x: FloatArray, length: int) -> float:
    """How much the block bootstrap with blocks of ``length`` under-estimates the variance
    of the mean of ``x``: the long-run variance (flat-top estimate, lag window M of
    :func:`block_length`) over what the bootstrap estimates, the Bartlett-weighted sum
    ``sum_{|k|<b} (1 - |k|/b) R(k)`` (Kuensch 1989); at least 1."""
    x = np.asarray(x, dtype=np.float64)
    if x.shape[0] < 4 or length <= 1:
        return 1.0
    m, acv, _cap = _flat_top(x)
    if m == 0:
        return 1.0
    _lags, lam = _window(m)
    long_run = float(acv[0] + np.sum(2.0 * lam * acv[1 : m + 1]))
    lags = np.arange(1, min(length, acv.shape[0]), dtype=np.float64)
    seen = float(acv[0] + np.sum(2.0 * (1.0 - lags / length) * acv[1 : lags.shape[0] + 1]))
    return max(1.0, long_run / seen) if seen > 0 and long_run > 0 else 1.0


#: Most blocks a resample is drawn from one by one; beyond, the sum of its k block sums
#: is drawn from the normal law of a sum of k independent draws (module doc). At k = 64
#: the skewness of a sum of exponential block sums is 0.25 (2 / sqrt k); the intervals
#: use the resamples' spread only, which the normal law gives exactly.
EXACT_BLOCKS = 64


@dataclass(frozen=True)
class Blocks:
    """The blocks of B resamples of a series of ``n`` epochs: block ``length`` b, ``count``
    k = ceil(n / b) blocks a resample, each starting anywhere in ``0 .. n - 1``
    (circular: a block running past the last epoch goes on at the first); each resample
    has ``k b`` epochs. ``starts`` (B, k): the drawn starts when k <= :data:`EXACT_BLOCKS`;
    else None and ``rng`` draws the sums' normal law (:func:`resampled_sums`)."""

    n: int
    length: int
    starts: IntArray | None
    count: int = 0
    resamples: int = 0
    rng: np.random.Generator | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.starts is not None:  # given starts: their shape says k and B
            object.__setattr__(self, "count", int(self.starts.shape[1]))
            object.__setattr__(self, "resamples", int(self.starts.shape[0]))

    @property
    def size(self) -> int:
        """Epochs of one resample (k b)."""
        return self.count * self.length

    @property
    def dof(self) -> float:
        """Degrees of freedom of the bootstrap's variance: ``1.5 (n / b - 1)``, those of
        overlapping batch means (Meketon & Schmeiser 1984), at least 1."""
        return max(1.0, 1.5 * (self.n / self.length - 1.0))


def draw_blocks(n: int, length: int, resamples: int, rng: np.random.Generator) -> Blocks:
    """B = ``resamples`` resamples' block starts, uniform in ``0 .. n - 1`` (more than
    :data:`EXACT_BLOCKS` a resample: the generator, for the normal law of their sums)."""
    length = int(min(max(length, 1), n))
    k = -(-n // length)
    if k > EXACT_BLOCKS:
        return Blocks(n, length, None, k, resamples, rng)
    starts = rng.integers(0, n, size=(resamples, k), dtype=np.int64)
    return Blocks(n, length, starts)


#: Largest skewness of a resample's sum (the block sums' skewness over sqrt k) drawn from
#: the normal law; beyond, the blocks are drawn: a pair whose reference distance barely
#: changes has squared steps mostly near 0 and a few large (skewness 8 and more), whose
#: normal law put 16 % of the sums of 271 blocks below zero.
MAX_SKEWNESS = 0.25


def _skewed(block_sums: FloatArray, k: int) -> bool:
    """True when a sum of k draws of some column is too skewed for its normal law."""
    centred = block_sums - block_sums.mean(axis=0)
    squared = centred * centred
    var = np.mean(squared, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        # the cube as two products: ``centred**3`` calls pow() per value, 40 x slower (it
        # was 9 of the 17 s of evaluation.csv's intervals at 10 x 4 h, issue 35)
        skew = np.mean(squared * centred, axis=0) / var**1.5
    skew = np.where(var > 0, np.abs(skew), 0.0)
    return bool(np.any(skew / math.sqrt(k) > MAX_SKEWNESS))


def _normal_sums(blocks: Blocks, block_sums: FloatArray) -> FloatArray:
    """B sums of k independent draws of the rows of ``block_sums`` (n, m), from their
    normal law: mean k mu, covariance k Sigma (mu, Sigma of the rows; a singular Sigma,
    e.g. two equal columns, keeps its null directions exactly)."""
    assert blocks.rng is not None
    k = blocks.count
    mu = block_sums.mean(axis=0)
    centred = block_sums - mu
    cov = centred.T @ centred / block_sums.shape[0]
    values, vectors = np.linalg.eigh(cov)
    root = vectors * np.sqrt(np.clip(values, 0.0, None))  # cov = root @ root.T
    z = blocks.rng.standard_normal((blocks.resamples, block_sums.shape[1]))
    out = np.asarray(k * mu + math.sqrt(k) * (z @ root.T), dtype=np.float64)
    # sums of squares and counts stay >= 0 (a far tail of the normal law could cross 0)
    positive = np.all(block_sums >= 0.0, axis=0)
    out[:, positive] = np.maximum(out[:, positive], 0.0)
    return out


def resampled_sums(blocks: Blocks, values: FloatArray, *, diffs: bool = False) -> FloatArray:
    """Each resample's sum of ``values`` ((n,) or (n, m): one column per sum), (B,) or
    (B, m). ``diffs``: ``values`` has n - 1 rows, one per pair of consecutive epochs
    (``(d_{i+1} - d_i)^2``), and a block of b epochs holds b - 1 of them (a block
    across the end leaves out the step from the last epoch to the first)."""
    v = np.asarray(values, dtype=np.float64)
    one = v.ndim == 1
    v = v.reshape(v.shape[0], -1)
    b = blocks.length
    if diffs:  # the step last -> first is no step of the series: 0
        wrapped = np.concatenate((v, np.zeros((1, v.shape[1])), v[: max(b - 2, 0)]))
    else:
        wrapped = np.concatenate((v, v[: b - 1]))
    prefix = np.zeros((wrapped.shape[0] + 1, v.shape[1]))
    np.cumsum(wrapped, axis=0, out=prefix[1:])
    span = b - 1 if diffs else b
    n = blocks.n
    block_sums = prefix[span : span + n] - prefix[:n]  # (n, m): the block from each start
    starts = blocks.starts
    if starts is None and _skewed(block_sums, blocks.count):
        assert blocks.rng is not None  # the normal law would not do: draw the blocks
        starts = blocks.rng.integers(0, n, size=(blocks.resamples, blocks.count))
    if starts is None:
        out = _normal_sums(blocks, block_sums)
    else:  # one gather per column of the (B, k) starts
        out = np.stack(
            [np.take(block_sums[:, j], starts).sum(axis=1) for j in range(v.shape[1])],
            axis=1,
        )
    return out[:, 0] if one else out


def spread(samples: FloatArray) -> float:
    """Standard deviation of resampled statistics (NaN when more than 1 % are not
    finite: a statistic undefined on some resamples has no interval)."""
    x = np.asarray(samples, dtype=np.float64)
    ok = x[np.isfinite(x)]
    if ok.size < 0.99 * x.shape[0] or ok.size < 2:
        return float("nan")
    return float(np.std(ok, ddof=1))


def _t(level: float, dof: float) -> float:
    return float(t_ppf(0.5 + level / 2.0, dof))


def interval(value: float, sd: float, level: float, dof: float) -> tuple[float, float]:
    """``value +- t sd``, t the Student quantile of ``level`` at ``dof`` degrees of freedom."""
    if not (math.isfinite(value) and math.isfinite(sd)):
        return float("nan"), float("nan")
    half = _t(level, dof) * sd
    return value - half, value + half


def p_value(value: float, sd: float, dof: float) -> float:
    """Two-sided p-value of ``value = 0`` against ``value / sd`` ~ Student t (dof)."""
    if not (math.isfinite(value) and math.isfinite(sd)):
        return float("nan")
    if sd == 0:
        return 1.0 if value == 0 else 0.0
    return float(2.0 * t_sf(abs(value) / sd, dof))


def quantile_interval(
    x: FloatArray, q: float, blocks: Blocks, level: float, ratio: float = 1.0
) -> tuple[float, float]:
    """Woodruff's interval of the ``q`` quantile of ``x`` (time order; module doc)."""
    x = np.asarray(x, dtype=np.float64)
    value = float(np.quantile(x, q))
    below = (x <= value).astype(np.float64)
    sd = spread(resampled_sums(blocks, below) / blocks.size) * math.sqrt(ratio)
    p_lo, p_hi = interval(q, sd, level, blocks.dof)
    if not (math.isfinite(p_lo) and math.isfinite(p_hi)):
        return float("nan"), float("nan")
    lo, hi = np.quantile(x, [min(max(p_lo, 0.0), 1.0), min(max(p_hi, 0.0), 1.0)])
    return float(lo), float(hi)
