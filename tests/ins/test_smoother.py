"""RTS smoothing over the full error state (coopproc.ins.smoother) through run_ins: in a
UWB outage the smoothed solution is far better than the forward one, and its covariance
is never larger."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.ins.engine import InsAiding, InsConfig, run_ins
from coopproc.ins.models import GRADES
from coopproc.ins.scenario import aided_scenario

OUTAGE = (20.0, 30.0)


@pytest.mark.parametrize("kind", ["circle", "straight"])
def test_smoothing_bridges_a_uwb_outage(kind: str) -> None:
    fig = GRADES["industrial"]
    sc = aided_scenario(kind, fig, 40.0, seed=3, outage=OUTAGE)  # type: ignore[arg-type]
    aid = InsAiding(ranges=sc.aiding.ranges, robust=(3.0, 4.5))
    cfg = InsConfig(fig, sc.origin_llh, sc.alignment, start_enu=np.zeros(3),
                    start_vel_enu=sc.truth_vel[0], smooth=True)  # fmt: skip
    res = run_ins(sc.imu, aid, cfg)
    assert res.smoothed is not None and res.best is res.smoothed
    t = sc.imu.time_s
    inside = (t > OUTAGE[0]) & (t < OUTAGE[1])
    before = (t > 10.0) & (t < OUTAGE[0])
    e_f = np.hypot(*(res.forward.enu_m - sc.truth_enu)[:, :2].T)
    e_s = np.hypot(*(res.smoothed.enu_m - sc.truth_enu)[:, :2].T)
    # ranges at 10 Hz, sigma 5 cm, to 4 anchors: a few cm while aided
    assert np.sqrt(np.mean(e_f[before] ** 2)) < 0.06
    # 10 s without UWB: the forward solution drifts (residual biases, 1/2 b t^2 with
    # the industrial 0.2 mg instability and the attitude error: decimetres) ...
    assert e_f[inside].max() > 0.15
    assert e_f[inside].max() > 4.0 * np.sqrt(np.mean(e_f[before] ** 2))
    # ... the smoothed one is tied to both ends of the outage: at the UWB level
    assert e_s[inside].max() < 0.25 * e_f[inside].max()
    assert np.sqrt(np.mean(e_s[inside] ** 2)) < 0.06
    # and overall no worse than the forward solution
    assert np.sqrt(np.mean(e_s[t > 10.0] ** 2)) <= np.sqrt(np.mean(e_f[t > 10.0] ** 2))
    # covariance: smoothed <= filtered everywhere, much smaller inside the outage
    assert np.all(res.smoothed.sigma_enu <= res.forward.sigma_enu + 1e-12)
    mid = int(np.searchsorted(t, 0.5 * (OUTAGE[0] + OUTAGE[1])))
    assert np.all(res.smoothed.sigma_enu[mid, :2] < 0.3 * res.forward.sigma_enu[mid, :2])
    # and consistent with the smoothed error
    err_s = np.abs(res.smoothed.enu_m - sc.truth_enu)[t > 5.0, :2]
    assert np.mean(err_s < 3.0 * res.smoothed.sigma_enu[t > 5.0, :2]) > 0.95
    # the end of the run has no future: smoothed == forward there
    assert np.abs(res.smoothed.enu_m[-1] - res.forward.enu_m[-1]).max() < 1e-9
