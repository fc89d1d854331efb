"""The GPS-only filter of ``tight`` on the real GEONET files (static receivers 0759 and
3040, 2005 day 092, 120 epochs at 30 s, pseudoranges only: no Doppler in these files):
the same accuracy as the SPP against the header position (tests/gnss/test_spp.py), and
20 m pseudorange errors kept out by the robust filter but not by the standard one.
Skipped without ../shared/data/gnss."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from coopproc import frames
from coopproc.gnss.receiver import GnssReceiver
from coopproc.gnss.rinex_nav import read_nav
from coopproc.gnss.rinex_obs import read_obs
from coopproc.gnss.tight import local_frame, prepare
from coopproc.stages.gnss.tight_filter import RangeRows, TightOptions, run_tight

DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "gnss"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="shared/data/gnss is not present")
EMPTY = RangeRows(np.empty(0), (), (), np.empty(0), np.empty(0))


def _run(station: str, **options: object) -> np.ndarray:
    obs = read_obs(DATA / f"{station}0920.05o")
    eph = read_nav(DATA / f"{station}0920.05n")
    assert obs.approx_position_ecef_m is not None
    llh = frames.ecef2geodetic(obs.approx_position_ecef_m[None, :])[0]
    frame = local_frame((float(llh[0]), float(llh[1]), float(llh[2])))
    ep = prepare(GnssReceiver(station, obs, eph, 0.0))
    start = {station: np.array([30.0, -20.0, 10.0])}  # 38 m off: it must converge
    opt = TightOptions(uwb=False, **options)  # type: ignore[arg-type]
    out = run_tight({station: ep}, start, frame, EMPTY, lambda p, t: None, opt)
    return np.asarray(out[station].state)[:, :3]  # ENU error: the origin is the truth


@pytest.mark.parametrize("station", ["0759", "3040"])
def test_gps_filter_accuracy_on_real_data(station: str) -> None:
    enu = _run(station)[10:]
    assert np.median(np.linalg.norm(enu, axis=1)) <= 1.5  # SPP: 0.68 / 0.89 m
    assert np.median(np.hypot(enu[:, 0], enu[:, 1])) <= 1.0  # SPP: 0.45 / 0.60 m


def test_real_pseudorange_gross_errors() -> None:
    # a static receiver's process noise (30 s between epochs: the vehicle default 0.5
    # m^2/s^3 leaves the prediction too weak to tell one satellite from the others)
    static = {"q_h": 1e-4, "q_v": 1e-4}
    obs = read_obs(DATA / "07590920.05o")
    base = {r: _run("0759", robust=r, **static) for r in (True, False)}
    kept_out = 0
    prns = obs.prn[obs.epoch_index == 60][1:5]  # the first is below the mask
    for prn in prns:
        gross = {("0759", 60): {int(prn): 20.0}}
        for robust in (True, False):
            hit = _run("0759", robust=robust, gross=gross, **static)
            shift = float(np.linalg.norm(hit - base[robust], axis=1).max())
            if robust:
                kept_out += shift < 1.0
            else:
                assert shift > 5.0  # the standard KF takes every one of them
    assert kept_out == len(prns)  # measured: 7 of 7 at this epoch (< 0.45 m)
