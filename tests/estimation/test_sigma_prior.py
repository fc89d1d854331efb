"""The declared sigma combined with the data's estimate (coopproc.estimation.sigma_prior)."""

from __future__ import annotations

import math

from coopproc.estimation.sigma_prior import PRIOR_EPOCHS, posterior_sigma


def test_prior_and_estimate_are_weighted_by_epochs_on_the_variance() -> None:
    # 20 epochs of data against a prior worth 20: sqrt((0.1^2 + 0.2^2) / 2)
    assert PRIOR_EPOCHS == 20.0
    assert math.isclose(posterior_sigma(0.1, 0.2, 20), math.sqrt(0.025), rel_tol=1e-12)
    # a long session: the data dominate
    assert math.isclose(posterior_sigma(0.1, 0.2, 19_980), math.sqrt(0.039970), rel_tol=1e-9)


def test_missing_prior_or_estimate() -> None:
    assert posterior_sigma(None, 0.3, 5) == 0.3
    assert posterior_sigma(0.1, float("nan"), 50) == 0.1
    assert posterior_sigma(0.1, 0.3, 0) == 0.1
    assert math.isnan(posterior_sigma(None, float("nan"), 10))
