"""The array-form INS engine (coopproc.ins.engine.run_ins) on aided synthetic runs."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.errors import StageError
from coopproc.ins.engine import InsAiding, InsConfig, PositionObs, run_ins, static_mask
from coopproc.ins.models import GRADES
from coopproc.ins.scenario import aided_scenario


def test_ranges_odometer_and_nhc_hold_an_industrial_imu_on_the_circle() -> None:
    fig = GRADES["industrial"]
    sc = aided_scenario("circle", fig, 30.0, seed=3)
    aid = InsAiding(ranges=sc.aiding.ranges, speed=sc.aiding.speed, robust=(3.0, 4.5), nhc=True)
    cfg = InsConfig(fig, sc.origin_llh, sc.alignment, start_enu=np.zeros(3),
                    start_vel_enu=sc.truth_vel[0], engine="plain")  # fmt: skip
    res = run_ins(sc.imu, aid, cfg)
    err = res.forward.enu_m - sc.truth_enu
    late = slice(2000, None)  # after 10 s
    horiz = np.hypot(err[late, 0], err[late, 1])
    assert np.sqrt(np.mean(horiz**2)) < 0.05
    assert np.abs(err[late, 2]).max() < 0.2
    # the filter's sigma covers the error, and is not absurdly loose
    assert np.mean(np.abs(err[late, 0]) < 3 * res.forward.sigma_enu[late, 0]) > 0.95
    assert res.forward.sigma_enu[late, 0].max() < 0.2
    vel_err = res.forward.vel_enu[late] - sc.truth_vel[late]
    assert np.sqrt(np.mean(vel_err[:, :2] ** 2)) < 0.05
    yaw_err = np.angle(np.exp(1j * (np.radians(res.forward.att_deg[:, 2]) - sc.truth_yaw)))
    # 3 deg at the start; NHC (lateral body velocity zero) makes the heading observable
    assert np.degrees(np.abs(yaw_err[late])).max() < 0.5
    stats = {s.kind: s for s in res.stats}
    assert set(stats) == {"range", "speed", "nhc"}
    assert stats["range"].count == sc.aiding.ranges.time_s.size
    assert stats["speed"].count == sc.aiding.speed.time_s.size
    assert 0.5 < stats["range"].nis_rms < 2.0
    assert stats["range"].rejected == 0
    assert res.smoothed is None and res.best is res.forward


def test_an_nlos_range_is_rejected_and_counted() -> None:
    fig = GRADES["industrial"]
    sc = aided_scenario("straight", fig, 10.0, seed=4, odo_hz=0.0)
    r = sc.aiding.ranges
    bad = r.range_m.copy()
    bad[200] += 3.0
    aid = InsAiding(ranges=type(r)(r.time_s, r.point_enu, bad, r.sigma_m, r.lever_b),
                    robust=(3.0, 4.5), nhc=True)  # fmt: skip
    cfg = InsConfig(fig, sc.origin_llh, sc.alignment, start_enu=np.zeros(3),
                    start_vel_enu=sc.truth_vel[0], engine="plain")  # fmt: skip
    res = run_ins(sc.imu, aid, cfg)
    stats = {s.kind: s for s in res.stats}
    assert stats["range"].rejected == 1
    assert stats["nhc"].count == 2 * 100  # 10 Hz, samples 20, 40, ..., 2000
    k = np.searchsorted(sc.imu.time_s, r.time_s[200])
    assert np.hypot(*(res.forward.enu_m[k, :2] - sc.truth_enu[k, :2])) < 0.1


def test_start_position_from_the_positions_and_one_line_errors() -> None:
    fig = GRADES["industrial"]
    sc = aided_scenario("straight", fig, 4.0, seed=5, odo_hz=0.0)
    t = sc.imu.time_s[::40]
    pos = PositionObs(t, sc.truth_enu[::40] + 0.01, np.full((t.size, 3), 0.05))
    cfg = InsConfig(fig, sc.origin_llh, sc.alignment, start_vel_enu=sc.truth_vel[0],
                    engine="plain")  # fmt: skip
    res = run_ins(sc.imu, InsAiding(positions=pos), cfg)
    assert np.abs(res.forward.enu_m[0] - (sc.truth_enu[0] + 0.01)).max() < 1e-6
    assert np.abs(res.forward.enu_m[-1] - sc.truth_enu[-1]).max() < 0.1
    assert {s.kind for s in res.stats} == {"position"}
    with pytest.raises(StageError, match="no start position"):
        run_ins(sc.imu, InsAiding(), cfg)


def test_static_mask_needs_the_odometer_to_call_a_straight_drive_moving() -> None:
    fig = GRADES["navigation"]
    sc = aided_scenario("straight", fig, 3.0, seed=6)
    assert static_mask(sc.imu).all()  # constant velocity looks like rest to an IMU
    assert not static_mask(sc.imu, sc.aiding.speed).any()


def test_session_origin_is_none_for_the_readers_placeholder() -> None:
    from types import SimpleNamespace

    from coopproc.ins.engine import DEFAULT_ORIGIN_LLH, session_origin

    def fake(given: object, used: tuple[float, float, float]) -> object:
        return SimpleNamespace(config=SimpleNamespace(origin_llh=given), origin_llh=used)

    assert session_origin(fake(None, (0.0, 0.0, 0.0))) is None  # type: ignore[arg-type]
    assert session_origin(fake(None, (48.1, 11.5, 520.0))) == (48.1, 11.5, 520.0)  # type: ignore[arg-type]
    assert session_origin(fake((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))) == (0.0, 0.0, 0.0)  # type: ignore[arg-type]
    assert DEFAULT_ORIGIN_LLH[0] == 45.0
