"""The DR DI's navigation corrected by the fusion's DR states (shared/dr_corrected.py)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from coopproc.model import Trajectory
from coopproc.stages.shared.dr_corrected import corrected_navigation


def _truth_and_dr(theta_deg: float, scale_error: float) -> tuple[Trajectory, Trajectory]:
    """A circle driven at 1 m/s and the dead reckoning of it whose steps read
    ``theta_deg`` too far clockwise and (1 + scale_error) too long."""
    t = np.arange(0.0, 120.0, 0.1)
    ang = t / 20.0
    truth = np.c_[20.0 * np.sin(ang), 20.0 * (1.0 - np.cos(ang)), np.full(t.shape, 1.5)]
    d = np.diff(truth, axis=0)
    a = np.radians(-theta_deg)  # clockwise: a negative (counter-clockwise) rotation
    de = (1.0 + scale_error) * (np.cos(a) * d[:, 0] - np.sin(a) * d[:, 1])
    dn = (1.0 + scale_error) * (np.sin(a) * d[:, 0] + np.cos(a) * d[:, 1])
    dr = truth.copy()
    dr[1:, 0] = truth[0, 0] + np.cumsum(de)
    dr[1:, 1] = truth[0, 1] + np.cumsum(dn)
    return Trajectory("A", t, truth), Trajectory("A", t, dr)


def _states(theta_deg: float, scale_error: float) -> pd.DataFrame:
    """dr_states.csv's rows of one platform: the DR's own errors, constant."""
    return pd.DataFrame(
        {"time": [0.0, 60.0, 120.0], "heading_error": theta_deg, "scale_error": scale_error}
    )


def test_known_heading_and_scale_errors_are_undone() -> None:
    truth, dr = _truth_and_dr(5.0, 0.004)
    assert np.abs(dr.enu_m - truth.enu_m).max() > 3.0  # 5 deg over a 120 m arc
    fixed = corrected_navigation(dr, _states(5.0, 0.004))
    np.testing.assert_allclose(fixed.enu_m, truth.enu_m, atol=1e-9)
    assert fixed.vel_enu_mps is dr.vel_enu_mps  # the RN method's velocities as recorded


def test_the_sign_convention_matters() -> None:
    """The opposite heading error doubles the error instead (dr_states.csv: a DR heading
    that reads too far clockwise has a positive heading_error)."""
    truth, dr = _truth_and_dr(5.0, 0.0)
    wrong = corrected_navigation(dr, _states(-5.0, 0.0))
    assert np.abs(wrong.enu_m - truth.enu_m).max() > 1.9 * np.abs(dr.enu_m - truth.enu_m).max()


def test_no_states_leave_the_navigation_as_it_is() -> None:
    _, dr = _truth_and_dr(5.0, 0.0)
    assert corrected_navigation(dr, _states(0.0, 0.0)).enu_m.tolist() == dr.enu_m.tolist()
    assert corrected_navigation(dr, _states(0.0, 0.0).iloc[:0]) is dr
