"""The compiled INS loop (coopproc.ins.kernels.forward) against the plain one
(coopproc.ins.loop.run_events): the same solution to rounding."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from coopproc.ins.engine import InsAiding, InsConfig, PositionObs, run_ins
from coopproc.ins.models import GRADES
from coopproc.ins.scenario import aided_scenario


@pytest.mark.parametrize("scale_factors", [False, True])
def test_compiled_loop_equals_the_plain_loop(scale_factors: bool) -> None:
    fig = GRADES["consumer"]
    sc = aided_scenario("straight", fig, 6.0, seed=8, lever_b=(0.3, -0.2, 0.9))
    r = sc.aiding.ranges
    assert r is not None
    bad = r.range_m.copy()
    bad[37] += 0.4  # down-weighted by IGG-III
    bad[90] += 5.0  # rejected
    t = sc.imu.time_s[5::50]  # positions between IMU samples
    tp = t + 0.0021
    pos = PositionObs(tp, sc.truth_enu[5::50] + 0.02, np.full((t.size, 3), 0.1))
    aid = InsAiding(
        ranges=replace(r, range_m=bad), positions=pos, speed=sc.aiding.speed, nhc=True,
        nhc_lever_b=np.array([-0.5, 0.0, -0.3]), zupt=True, robust=(1.5, 4.0),
    )  # fmt: skip
    cfg = InsConfig(fig, sc.origin_llh, sc.alignment, start_enu=np.zeros(3),
                    start_vel_enu=sc.truth_vel[0], scale_factors=scale_factors,
                    cov_every=7, engine="plain")  # fmt: skip
    plain = run_ins(sc.imu, aid, cfg)
    seen: list[float] = []
    compiled = run_ins(sc.imu, aid, replace(cfg, engine="compiled"), progress=seen.append)
    assert seen and seen[-1] == 1.0
    for a, b in ((plain.forward, compiled.forward),):
        assert np.abs(a.enu_m - b.enu_m).max() < 1e-6
        assert np.abs(a.vel_enu - b.vel_enu).max() < 1e-8
        assert np.abs(a.att_deg - b.att_deg).max() < 1e-7
        assert np.abs(a.sigma_enu - b.sigma_enu).max() < 1e-9
    for sp, sc_ in zip(plain.stats, compiled.stats, strict=True):
        assert (sp.kind, sp.count, sp.accepted, sp.downweighted, sp.rejected) == (
            sc_.kind, sc_.count, sc_.accepted, sc_.downweighted, sc_.rejected)  # fmt: skip
        assert sp.nis_rms == pytest.approx(sc_.nis_rms, rel=1e-6)
    kinds = {s.kind: s for s in compiled.stats}
    # every aiding kind was used; the outliers were down-weighted and rejected
    assert set(kinds) == {"range", "position", "speed", "nhc"}
    assert kinds["range"].rejected >= 1 and kinds["range"].downweighted >= 1
    # and the solution is a good one (not two equal failures)
    assert np.abs(compiled.forward.enu_m[400:] - sc.truth_enu[400:]).max() < 0.1


def test_zero_velocity_updates_hold_a_resting_imu_in_both_loops() -> None:
    fig = GRADES["industrial"]
    sc = aided_scenario("straight", fig, 10.0, seed=9, speed_mps=0.0, odo_sigma_mps=0.002)
    aid = InsAiding(speed=sc.aiding.speed, zupt=True)
    cfg = InsConfig(fig, sc.origin_llh, sc.alignment, start_enu=np.zeros(3), engine="plain")
    plain = run_ins(sc.imu, aid, cfg)
    compiled = run_ins(sc.imu, aid, replace(cfg, engine="compiled"))
    assert np.abs(plain.forward.enu_m - compiled.forward.enu_m).max() < 1e-6
    kinds = {s.kind: s for s in compiled.stats}
    # at rest every 0.1 s (the odometer says 0 too): 3 rows each
    assert kinds["zupt"].count == 3 * 100
    assert kinds["speed"].count == sc.aiding.speed.time_s.size  # type: ignore[union-attr]
    free = run_ins(sc.imu, InsAiding(), replace(cfg, engine="compiled"))
    drift_free = np.abs(free.forward.enu_m[-1, :2]).max()
    # turn-on biases of 5 mg: 1/2 b t^2 of metres in 10 s without the updates
    assert drift_free > 0.5
    assert np.abs(compiled.forward.enu_m[:, :2]).max() < 0.02 * drift_free
    assert np.abs(compiled.forward.vel_enu).max() < 0.01
