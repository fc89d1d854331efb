"""A declared ranging sigma combined with the data's estimate of it, on the variance.

Taken by the ranging stage (the detection threshold's spread, paper 000 eq. (9);
:mod:`coopproc.stages.ranging.local`) and by the fusion's self-calibration (each pair's
sigma from the post-fit residuals; :mod:`coopproc.stages.fusion.calibration`), so it lives
below both rooms.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PRIOR_EPOCHS", "posterior_sigma"]

#: Weight of a declared sigma, in epochs, when it is combined with a data estimate.
PRIOR_EPOCHS = 20.0


def posterior_sigma(prior_m: float | None, estimate_m: float, samples: int) -> float:
    """The declared sigma (a prior worth :data:`PRIOR_EPOCHS` epochs) combined with a data
    estimate from ``samples`` epochs, on the variance: the data dominate long sessions.
    Without a prior the estimate; without an estimate the prior."""
    if not np.isfinite(estimate_m) or samples <= 0:
        return float(prior_m) if prior_m is not None else float("nan")
    if prior_m is None:
        return float(estimate_m)
    var = (PRIOR_EPOCHS * prior_m**2 + samples * estimate_m**2) / (PRIOR_EPOCHS + samples)
    return float(np.sqrt(var))
