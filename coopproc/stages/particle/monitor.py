"""Step 3 of the AACOPF (paper 004): which auxiliaries range well enough to be used.

:class:`AuxMonitor` keeps a window of residuals per auxiliary and rejects one whose
|mean| > Omega1 and variance > Omega2 (aacopf.py and docs/locate.md explain the reading
of the garbled text). Two additions of issue 17 (docs/locate.md, "Several auxiliaries,
one faulty"):

- :func:`ranging_noise_m2` estimates each auxiliary's ranging noise from its ranges
  alone (the deviation of each range from the line through its two neighbours), and
  :func:`ring_auxiliary` picks the quietest one to build the initial ring and to be the
  first reference: the first listed one may be the faulty one.
- a residual is only taken while the cloud predicts the auxiliary's range to within
  ``judge_spread_m`` (weighted standard deviation): against a ring or a multi-modal
  cloud the predicted range of another auxiliary spreads over tens of metres and its
  residual says nothing about its ranging (a good auxiliary was rejected for it).
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.locate_result import LocateInputs
from coopproc.model import FloatArray
from coopproc.stages.particle.params import LocateParams

__all__ = ["AuxMonitor", "ranging_noise_m2", "ring_auxiliary"]


def ranging_noise_m2(time_s: FloatArray, range_m: FloatArray) -> float:
    """Ranging noise variance of one auxiliary from its ranges alone (m^2; inf if < 3).

    Each inner range is compared with the straight line through its neighbours:
    e_i = z_i - (z_(i-1) + a (z_(i+1) - z_(i-1))), a the time fraction; for white noise
    E[e^2] = s^2 (1 + a^2 + (1 - a)^2). The smooth relative motion cancels to first
    order; a heavy tail or a Laplace error raises the mean square (no robust estimate on
    purpose: the outliers are what is looked for).
    """
    ok = np.isfinite(range_m)
    t, z = time_s[ok], range_m[ok]
    if z.shape[0] < 3:
        return float("inf")
    span = t[2:] - t[:-2]
    a = np.where(span > 0, (t[1:-1] - t[:-2]) / np.where(span > 0, span, 1.0), 0.5)
    e = z[1:-1] - (z[:-2] + a * (z[2:] - z[:-2]))
    return float(np.mean(e**2 / (1.0 + a**2 + (1.0 - a) ** 2)))


def ring_auxiliary(inputs: LocateInputs) -> int:
    """The auxiliary whose ranges are the least noisy (ties: the first listed)."""
    noise = [ranging_noise_m2(inputs.time_s, inputs.range_m[:, j]) for j in range(len(inputs.aux))]
    return int(np.argmin(noise))


class AuxMonitor:
    """Step 3: per-auxiliary residual windows and the reject / down-weight decision."""

    def __init__(self, n_aux: int, params: LocateParams, ref: int = -1) -> None:
        self.window = params.residual_window
        self.buf = np.full((n_aux, self.window), np.nan)
        self.count = np.zeros(n_aux, dtype=np.int64)
        self.omega1 = params.Omega1
        self.omega2 = params.Omega2
        #: Auxiliaries whose last decision was made on a full window next to another one.
        self.judged = np.zeros(n_aux, dtype=bool)
        #: The reference auxiliary (smallest D[rho]; at first the ring's, issue 17), -1: none.
        self.ref = ref
        #: Eliminated auxiliaries; one stays out until its window is clean again.
        self.out = np.zeros(n_aux, dtype=bool)
        # running ranging-noise estimate of each auxiliary from its own ranges (see
        # ranging_noise_m2): the last two (time, range), the sum of terms and their count
        self._last = np.full((n_aux, 2, 2), np.nan)
        self._noise_sum = np.zeros(n_aux)
        self._noise_count = np.zeros(n_aux, dtype=np.int64)

    def add_range(self, j: int, time_s: float, range_m: float) -> None:
        """One more range of auxiliary j: updates its ranging-noise estimate."""
        (t0, z0), (t1, z1) = self._last[j]
        if np.isfinite(z0) and time_s > t0:
            a = (t1 - t0) / (time_s - t0)
            e = z1 - (z0 + a * (range_m - z0))
            self._noise_sum[j] += e * e / (1.0 + a * a + (1.0 - a) ** 2)
            self._noise_count[j] += 1
        self._last[j, 0] = self._last[j, 1]
        self._last[j, 1] = (time_s, range_m)

    def ranging_noise_m2(self) -> np.ndarray:
        """The ranges' own noise variance per auxiliary so far (NaN before 2 terms)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(
                self._noise_count >= 2, self._noise_sum / np.maximum(self._noise_count, 1), np.nan
            )

    def add(self, j: int, residual_m: float) -> None:
        self.buf[j, self.count[j] % self.window] = residual_m
        self.count[j] += 1

    def decide(self, nominal_var_m2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(use (J,) bool, inflate_m (J,)) from the current residual windows.

        Only auxiliaries with a full window are judged, and only when at least two are:
        a lone auxiliary is never rejected (the filter would be blind). The auxiliary
        with the smallest residual variance is the reference and is always used as is.
        Another one is rejected when |mean| > Omega1 and variance > Omega2 (paper), or
        (issue 17) when its ranges by themselves scatter by more than Omega2 over a full
        window or more (:meth:`ranging_noise_m2`, blind to the estimate, whose own error
        otherwise hides or fakes a peak shift); if kept, its likelihood sigma is widened
        by its excess variance and, when its |mean| > Omega1, by its mean
        (down-weighting).
        """
        n_aux = self.buf.shape[0]
        use = np.ones(n_aux, dtype=bool)
        inflate = np.zeros(n_aux)
        full = self.count >= self.window
        self.judged = full if full.sum() >= 2 else np.zeros(n_aux, dtype=bool)
        if full.sum() < 2:
            return use, inflate
        # buffer in time order, to difference successive residuals
        order = (self.count[:, None] + np.arange(self.window)[None, :]) % self.window
        buf = np.take_along_axis(np.where(full[:, None], self.buf, 0.0), order, axis=1)
        mean = np.where(full, buf.mean(axis=1), 0.0)
        # D[rho] from successive differences (var(diff) / 2): the slowly varying error of
        # the estimate itself cancels, the auxiliary's own ranging noise stays
        var = np.where(full, 0.5 * np.mean(np.diff(buf, axis=1) ** 2, axis=1), 0.0)
        own = self.ranging_noise_m2()
        rough = (self._noise_count >= self.window) & (own > self.omega2)
        # the reference changes only to an auxiliary at least twice as consistent
        cand = int(np.argmin(np.where(full & ~rough, var, np.inf)))
        if self.ref < 0 or not full[self.ref] or var[cand] < 0.5 * var[self.ref]:
            self.ref = cand
        ref = self.ref
        biased = full & (np.abs(mean) > self.omega1)
        noisy = full & (var > self.omega2)
        # E[rho] > Omega1 & D[rho] > Omega2 eliminates; back only once both are below
        self.out = (self.out & (biased | noisy)) | (biased & noisy) | rough
        self.out[ref] = False
        reject = self.out.copy()
        excess = np.where(full, np.maximum(var - nominal_var_m2, 0.0), 0.0)
        inflate = np.sqrt(excess + np.where(biased, mean**2, 0.0))
        inflate[ref] = 0.0
        return ~reject, np.where(reject, 0.0, inflate)
