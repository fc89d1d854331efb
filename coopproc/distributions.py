"""Student t and chi-square quantiles without importing ``scipy.stats``.

``scipy.stats`` takes ~0.8 s CPU to import (its 100-odd distributions, and
``scipy.optimize``, ``integrate`` and ``interpolate`` with them), on every ``coopproc
run``, for five numbers of this kind: the bootstrap intervals' Student quantiles
(report/bootstrap.py), the chi-square bounds of the consistency figure and table
(report/consistency*.py) and of the residual tests (stages/anchors/anchor_lsq.py,
gnss/spp.py). These are the same ``scipy.special`` functions ``scipy.stats`` evaluates
for them (``t.ppf``: ``stdtrit(df, q)``, ``t.sf``: ``stdtr(df, -x)``, ``chi2.ppf``:
``2 gammaincinv(df / 2, q)``, scipy 1.17) with its handling of the ends and of invalid
arguments, so the numbers are the same to the bit (tests/test_distributions.py compares
them on a grid).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

__all__ = ["chi2_ppf", "t_ppf", "t_sf"]


def _ppf(
    q: ArrayLike, dof: ArrayLike, lower: float, quantile: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``scipy.stats``' ends and NaNs around ``quantile``: NaN where dof <= 0 or q is not
    in [0, 1], the support's ends at q = 0 and 1."""
    q = np.asarray(q, dtype=np.float64)
    dof = np.asarray(dof, dtype=np.float64)
    ok = dof > 0
    out = np.where(ok & (q > 0) & (q < 1), quantile, np.nan)
    out = np.where(ok & (q == 0), lower, out)
    return np.where(ok & (q == 1), np.inf, out)


def t_ppf(q: ArrayLike, dof: ArrayLike) -> NDArray[np.float64]:
    """``scipy.stats.t.ppf(q, dof)``."""
    with np.errstate(invalid="ignore"):
        return _ppf(q, dof, -np.inf, special.stdtrit(dof, q))


def t_sf(x: ArrayLike, dof: ArrayLike) -> NDArray[np.float64]:
    """``scipy.stats.t.sf(x, dof)``."""
    x = np.asarray(x, dtype=np.float64)
    dof = np.asarray(dof, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        out = np.where(dof > 0, special.stdtr(dof, -x), np.nan)
    return np.where(np.isnan(x), np.nan, out)


def chi2_ppf(q: ArrayLike, dof: ArrayLike) -> NDArray[np.float64]:
    """``scipy.stats.chi2.ppf(q, dof)``."""
    dof = np.asarray(dof, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return _ppf(q, dof, 0.0, 2 * special.gammaincinv(dof / 2, q))
