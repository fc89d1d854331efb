"""Stochastic analysis of the UWB range errors, per pair (paper 002 sec. 5.1).

Paper 002 sets its filter's range noise from the residuals of a 718-epoch, 1 Hz series
of UWB ranges against total-station distances: their autocorrelation ("the unbiased
estimate of the autocorrelation coefficient") and their probability density, found to be
close to Gaussian, whose variance it then uses in the robust Kalman filter. It picked a
static line-of-sight series by hand; on a run's ``ranges.csv`` the epochs are picked as
follows, per pair:

- **residual** r = ``observed - reference`` on every epoch with a reference distance;
- **line of sight (LOS)**: not flagged ``nlos_flag`` by the run, **and** not a robust
  outlier: |r - median| <= 3 x 1.4826 x MAD, median and MAD over the unflagged epochs
  (one pass; a MAD of 0 keeps every unflagged epoch);
- **statistics** of the LOS residuals: ``mean`` (the bias), ``std`` (sample, n - 1),
  ``robust_sigma`` (1.4826 MAD), ``skewness`` and ``kurtosis`` (excess: 0 for a Gaussian;
  both bias-corrected, scipy.stats ``bias=False``);
- **normality**: D'Agostino-Pearson K^2 (``scipy.stats.normaltest``): it tests exactly the
  skewness and kurtosis that matter for a filter's tails and holds for any n >= 20, where
  Shapiro-Wilk's p-value is only approximated up to n = 5000 (pairs have thousands of
  epochs). NaN below 20 epochs. Correlated residuals make its p-value too small;
- **autocorrelation** on irregular epochs (dropouts, removed NLOS spans) by **lag bins**
  (the slotted ACF): every product z_i z_j (z = r - mean) of epochs t_j - t_i apart
  falls into bin k = round((t_j - t_i) / dt), dt the pair's median range interval; ACF(k)
  = mean of the bin's products / mean of z^2 ("unbiased": divided by each bin's count).
  Lags up to a quarter of the LOS span, at most 200 intervals;
- **correlation time** ``corr_time_s``: the first lag at which the ACF drops below 1/e
  (linear interpolation between bins; NaN when it does not within the lags; when rho1 is
  below 1/e already, the crossing is inside the first interval and ``gm_tau_s`` is
  given);
  ``gm_tau_s`` = -dt / ln(rho1), the time constant of the first-order Gauss-Markov
  process whose AR(1) coefficient at the range rate is the lag-1 ACF ``rho1`` (0 when
  rho1 <= 0); the residuals are ``correlated`` when rho1 > 1.96 / sqrt(n);
- **suggested sigma** for ``session.toml [uwb] sigma``: the LOS ``std`` (its square
  ``variance_suggested``, as paper 002 reports 0.14 m^2); a white-noise filter that uses
  every range of correlated residuals needs the AR(1) long-run sigma
  ``sigma_inflated`` = std x sqrt((1 + rho1) / (1 - rho1)) (rho1 capped at 0.999), the
  std itself when they are not correlated.

``rms`` is the root mean square of the LOS residuals, bias included: what a filter that
does not estimate the range bias needs instead of ``std``.

The ``all`` row pools every pair's LOS residuals **about the pair's own mean**: ``std``
is the within-pair std (sum of squares / (N - pairs)), the noise once each pair's bias
is known (the biases are the pairs' ``mean``; ``mean`` and ``rms`` of ``all`` are those
of the raw pooled residuals, biases included); the shape statistics and the normality
test are those of the centred residuals; the ACF sums the lag products of every pair
(never across pairs), binned at the median of the pairs' intervals.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np
import pandas as pd

from coopproc.model import FloatArray
from coopproc.report.allan import ImuAllan

__all__ = [
    "MAD_SCALE",
    "STOCHASTIC_COLUMNS",
    "PairStochastics",
    "StochasticReport",
    "UwbNoise",
    "los_mask",
    "pair_stochastics",
    "slotted_acf",
    "stochastic_frame",
    "uwb_stochastics",
]

#: 1.4826 x MAD estimates the sigma of Gaussian data.
MAD_SCALE = 1.4826
#: Outlier limit in robust sigmas, lag-1 significance (two-sided 95 %), fewest epochs.
OUTLIER_SIGMAS = 3.0
_Z95 = 1.96
MIN_EPOCHS = 10
_MAX_LAG_BINS = 200
_RHO_CAP = 0.999


@dataclass(frozen=True)
class UwbNoise:
    """The statistics of one pair's (or ``all``) LOS range residuals: one row of
    ``stochastic.csv`` (the fields in order are its columns; see the module text)."""

    pair: str
    #: epochs with a reference, flagged NLOS by the run, robust outliers, LOS (used)
    epochs: int
    nlos_flagged: int
    outliers: int
    n: int
    #: the median range interval, s (the lag-bin width)
    interval_s: float
    #: m: bias, sample std (n - 1), root mean square, 1.4826 MAD
    mean: float
    std: float
    rms: float
    robust_sigma: float
    #: bias-corrected skewness and excess kurtosis (0 for a Gaussian)
    skewness: float
    kurtosis: float
    #: D'Agostino-Pearson K^2 and its p-value (NaN below 20 epochs)
    normal_stat: float
    normal_p: float
    #: lag-1 ACF, first 1/e crossing (s), Gauss-Markov time constant (s)
    rho1: float
    corr_time_s: float
    gm_tau_s: float
    #: rho1 above 1.96 / sqrt(n)
    correlated: bool
    #: m, m^2, m: [uwb] sigma, its square, the AR(1) long-run sigma
    sigma_suggested: float
    variance_suggested: float
    sigma_inflated: float

    def record(self) -> dict[str, str | int | float]:
        """The row as column -> value (``correlated`` as 0/1)."""
        out: dict[str, str | int | float] = dict(asdict(self))
        out["correlated"] = int(self.correlated)
        return out


#: Columns of ``stochastic.csv``, one row per pair and ``all``.
STOCHASTIC_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(UwbNoise))


@dataclass(frozen=True, eq=False)
class PairStochastics:
    """One pair's (or ``all``) LOS residuals, their ACF and their statistics.

    For ``all``, ``residual_m`` holds every pair's residuals about the pair's own mean
    (what its ``std`` describes)."""

    pair: str
    time_s: FloatArray
    residual_m: FloatArray
    acf_lag_s: FloatArray
    acf: FloatArray
    stats: UwbNoise


@dataclass(frozen=True, eq=False)
class StochasticReport:
    """What ``coopproc report OUT --stochastic`` found: UWB pairs, IMU results, notes.

    ``imu``: one Allan deviation result per IMU record.
    """

    uwb: tuple[PairStochastics, ...]
    imu: tuple[ImuAllan, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)


def los_mask(residual: FloatArray, flagged: np.ndarray) -> tuple[np.ndarray, int]:
    """LOS epochs (see the module text) and the number of robust outliers removed."""
    ok = ~flagged
    if not ok.any():
        return ok, 0
    med = float(np.median(residual[ok]))
    mad = float(np.median(np.abs(residual[ok] - med)))
    if mad == 0.0:
        return ok, 0
    inlier = np.abs(residual - med) <= OUTLIER_SIGMAS * MAD_SCALE * mad
    return ok & inlier, int(np.count_nonzero(ok & ~inlier))


def slotted_acf(
    time_s: FloatArray, z: FloatArray, interval_s: float, bins: int
) -> tuple[FloatArray, FloatArray]:
    """Sums and counts of the products z_i z_j per lag bin 0..bins (see the module text).

    Bin 0 holds the squares only (z_i^2, count n). Loops over the index offset (every
    offset vectorised) until the smallest time difference exceeds the last bin.
    """
    sums = np.zeros(bins + 1)
    counts = np.zeros(bins + 1)
    sums[0], counts[0] = float(np.sum(z * z)), float(z.size)
    limit = (bins + 0.5) * interval_s
    for m in range(1, z.size):
        dt = time_s[m:] - time_s[:-m]
        if dt.min() > limit:
            break
        k = np.rint(dt / interval_s).astype(np.int64)
        use = (k >= 1) & (k <= bins)
        sums += np.bincount(k[use], weights=(z[m:] * z[:-m])[use], minlength=bins + 1)[: bins + 1]
        counts += np.bincount(k[use], minlength=bins + 1)[: bins + 1]
    return sums, counts


def _acf_from(sums: FloatArray, counts: FloatArray) -> FloatArray:
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
    return np.asarray(mean / mean[0], dtype=np.float64)


def _crossing(lags: FloatArray, acf: FloatArray) -> float:
    """First lag at which the ACF drops below 1/e, interpolated between valid bins."""
    level = math.exp(-1.0)
    valid = np.flatnonzero(np.isfinite(acf))
    for a, b in itertools.pairwise(valid):
        if acf[b] < level:
            frac = (acf[a] - level) / (acf[a] - acf[b])
            return float(lags[a] + frac * (lags[b] - lags[a]))
    return float("nan")


def _noise(
    pair: str, r: FloatArray, acf: FloatArray, lags: FloatArray, interval: float
) -> UwbNoise:
    """Statistics of the residuals ``r`` (counts set to ``n``; callers replace them)."""
    from scipy import stats  # here: ~0.8 s to import, for `report --stochastic` only

    n = r.size
    std = float(np.std(r, ddof=1))
    med = float(np.median(r))
    if n >= 20:
        stat, p = stats.normaltest(r)
        normal = (float(stat), float(p))
    else:
        normal = (float("nan"), float("nan"))
    rho1 = float(acf[1]) if acf.size > 1 and np.isfinite(acf[1]) else float("nan")
    correlated = bool(np.isfinite(rho1) and rho1 > _Z95 / math.sqrt(n))
    rho = min(rho1, _RHO_CAP) if correlated else 0.0
    gm = -interval / math.log(min(rho1, _RHO_CAP)) if np.isfinite(rho1) and rho1 > 0 else 0.0
    return UwbNoise(
        pair=pair,
        epochs=n,
        nlos_flagged=0,
        outliers=0,
        n=n,
        interval_s=interval,
        mean=float(np.mean(r)),
        std=std,
        rms=float(np.sqrt(np.mean(r * r))),
        robust_sigma=MAD_SCALE * float(np.median(np.abs(r - med))),
        skewness=float(stats.skew(r, bias=False)),
        kurtosis=float(stats.kurtosis(r, fisher=True, bias=False)),
        normal_stat=normal[0],
        normal_p=normal[1],
        rho1=rho1,
        # below 1/e already at the first lag: within one interval, where only the
        # Gauss-Markov fit says where
        corr_time_s=gm if np.isfinite(rho1) and rho1 < math.exp(-1.0) else _crossing(lags, acf),
        gm_tau_s=gm,
        correlated=correlated,
        sigma_suggested=std,
        variance_suggested=std * std,
        sigma_inflated=std * math.sqrt((1.0 + rho) / (1.0 - rho)),
    )


def _bins(time_s: FloatArray, interval: float) -> int:
    span = float(time_s[-1] - time_s[0]) if time_s.size else 0.0
    return int(max(1, min(_MAX_LAG_BINS, math.floor(span / (4.0 * interval)))))


def pair_stochastics(
    pair: str, frame: pd.DataFrame, interval_s: float | None = None
) -> PairStochastics | None:
    """One pair's analysis from its ``ranges.csv`` rows; None below :data:`MIN_EPOCHS`
    LOS epochs. ``interval_s``: the lag-bin width (default: the pair's median interval)."""
    rows = frame[frame["reference"].notna()].sort_values("time", kind="stable")
    t_all = rows["time"].to_numpy(dtype=np.float64)
    r_all = (rows["observed"] - rows["reference"]).to_numpy(dtype=np.float64)
    flagged = rows["nlos_flag"].fillna(0).to_numpy(dtype=np.float64) != 0
    los, outliers = los_mask(r_all, flagged)
    t, r = t_all[los], r_all[los]
    if r.size < MIN_EPOCHS:
        return None
    interval = interval_s or float(np.median(np.diff(t_all)))
    bins = _bins(t, interval)
    sums, counts = slotted_acf(t, r - r.mean(), interval, bins)
    acf = _acf_from(sums, counts)
    lags = np.arange(bins + 1, dtype=np.float64) * interval
    noise = replace(
        _noise(pair, r, acf, lags, interval),
        epochs=int(r_all.size),
        nlos_flagged=int(flagged.sum()),
        outliers=outliers,
    )
    return PairStochastics(pair, t, r, lags, acf, noise)


def _pooled(pairs: Sequence[PairStochastics]) -> PairStochastics:
    """The ``all`` row: every pair's LOS residuals about its own mean (see the module)."""
    interval = float(np.median([p.stats.interval_s for p in pairs]))
    raw = np.concatenate([p.residual_m for p in pairs])
    centred = [p.residual_m - p.residual_m.mean() for p in pairs]
    t = np.concatenate([p.time_s for p in pairs])
    bins = min(_bins(p.time_s, interval) for p in pairs)
    sums = np.zeros(bins + 1)
    counts = np.zeros(bins + 1)
    for p, z in zip(pairs, centred, strict=True):  # lag products within each pair only
        s, c = slotted_acf(p.time_s, z, interval, bins)
        sums += s
        counts += c
    acf = _acf_from(sums, counts)
    lags = np.arange(bins + 1, dtype=np.float64) * interval
    r = np.concatenate(centred)
    pooled = _noise("all", r, acf, lags, interval)
    # within-pair std: each pair's n - 1 degrees of freedom
    std = math.sqrt(float(np.sum(r * r)) / (r.size - len(pairs)))
    noise = replace(
        pooled,
        epochs=sum(p.stats.epochs for p in pairs),
        nlos_flagged=sum(p.stats.nlos_flagged for p in pairs),
        outliers=sum(p.stats.outliers for p in pairs),
        mean=float(raw.mean()),
        rms=float(np.sqrt(np.mean(raw * raw))),
        std=std,
        sigma_suggested=std,
        variance_suggested=std * std,
        sigma_inflated=std * pooled.sigma_inflated / pooled.std,
    )
    return PairStochastics("all", t, r, lags, acf, noise)


def uwb_stochastics(ranges: pd.DataFrame) -> tuple[list[PairStochastics], list[str]]:
    """Every pair with at least :data:`MIN_EPOCHS` LOS epochs (sorted), then ``all`` when
    there are two or more; and a note for each pair left out."""
    out: list[PairStochastics] = []
    notes: list[str] = []
    for pair, frame in ranges.groupby("pair", sort=True):
        result = pair_stochastics(str(pair), frame)
        if result is None:
            notes.append(
                f"{pair}: fewer than {MIN_EPOCHS} line-of-sight epochs with a reference "
                "distance; left out of the stochastic analysis"
            )
        else:
            out.append(result)
    if len(out) > 1:
        out.append(_pooled(out))
    return out, notes


def stochastic_frame(pairs: Sequence[PairStochastics]) -> pd.DataFrame:
    """The ``stochastic.csv`` table (:data:`STOCHASTIC_COLUMNS`)."""
    frame = pd.DataFrame([p.stats.record() for p in pairs], columns=list(STOCHASTIC_COLUMNS))
    for col in ("epochs", "nlos_flagged", "outliers", "n", "correlated"):
        frame[col] = frame[col].astype(np.int64)
    return frame
