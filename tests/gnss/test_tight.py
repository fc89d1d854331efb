"""The tightly coupled GPS/UWB filter (issue 13 items 4-5) on a simulated session read
back from its files: a tag among four anchors, 60 s, canyon windows with 3, 2 and 1
satellites (paper 002 scenarios 1-6 in miniature).

Noise behind the bounds: UWB 0.15 m (session.toml), pseudoranges 0.5 m white + 0.3 m /
sin(el) multipath + 30 % of the Klobuchar delay per satellite (the simulator's defaults).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from coopproc.errors import InputError
from coopproc.gnss.tight import epoch_model, local_frame, pdop, prepare
from coopproc.io.session import read_session
from coopproc.model import Session
from coopproc.sim import simulate, write_simulation
from coopproc.sim.gnss_obs import default_nav_path
from coopproc.stages.gnss.tight_filter import TrackOutput
from coopproc.stages.gnss.tight_stage import GnssParams, GrossError, MaskWindow, solve

sys.path.insert(0, str(Path(__file__).parent))
from tight_kit import track_errors

pytestmark = pytest.mark.skipif(
    not default_nav_path().exists(), reason="shared/data/gnss is not present"
)
CANYON = [[10.0, 20.0, 3], [22.0, 32.0, 2], [34.0, 42.0, 1]]


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Session:
    sim = simulate("anchors", seed=1, duration_s=60, platforms=5, gnss_obs=True, canyon=CANYON)
    out = tmp_path_factory.mktemp("tight") / "sim"
    write_simulation(sim, out)
    return read_session(out)


@pytest.fixture(scope="module")
def runs(session: Session) -> dict[str, TrackOutput]:
    """The tag's GPS-only and tight robust solutions with every satellite."""
    gnss, _ = solve(session, session.ranges.frame, GnssParams(), uwb=False, robust=True)
    tight, _ = solve(session, session.ranges.frame, GnssParams(), uwb=True, robust=True)
    return {"gnss": gnss["tag"], "tight": tight["tag"]}


def _window(t: np.ndarray, i: int) -> np.ndarray:
    return (t >= CANYON[i][0] + 1.0) & (t <= CANYON[i][1])


def test_session_reads_the_receivers(session: Session) -> None:
    assert sorted(session.gnss) == ["AN1", "AN2", "AN3", "AN4", "tag"]
    rx = session.gnss["tag"]
    # the epochs land on the session's clock (gps_tow): the ranges' span
    t = rx.epoch_time_s
    r = session.ranges.frame["time"]
    assert abs(t[0] - r.min()) < 1.0 and abs(t[-1] - r.max()) < 1.5


def test_tight_at_least_as_good_as_gnss_with_enough_satellites(
    session: Session, runs: dict[str, TrackOutput]
) -> None:
    tg, eg, _ = track_errors(session, runs["gnss"])
    tt, et, _ = track_errors(session, runs["tight"])
    open_g = (tg > 2.0) & (tg < CANYON[0][0])  # 10 satellites
    open_t = (tt > 2.0) & (tt < CANYON[0][0])
    rms_g = float(np.sqrt(np.mean(eg[open_g] ** 2)))
    rms_t = float(np.sqrt(np.mean(et[open_t] ** 2)))
    assert rms_t <= rms_g
    assert rms_t < 0.5  # UWB 0.15 m from four anchors; GPS-only is about 0.8 m here


def test_two_or_three_satellites_with_uwb_stay_bounded(
    session: Session, runs: dict[str, TrackOutput]
) -> None:
    tg, eg, sg = track_errors(session, runs["gnss"])
    tt, et, st = track_errors(session, runs["tight"])
    for i in (0, 1):  # 3, then 2 satellites
        w = _window(tt, i)
        # bound: 3 x the 0.5 m typical horizontal sigma the filter reports there (UWB 0.15 m
        # through the anchors' geometry, plus the GPS vertical bias leaking in)
        assert et[w].max() < 1.5
        assert st[w].max() < 1.0  # its own 1-sigma (the bound is 1.5 times that)
    # GPS alone with 2 satellites: no fix, only the constant-velocity prediction; the
    # filter says so (horizontal sigma of metres) and its error is larger
    w2g, w2t = _window(tg, 1), _window(tt, 1)
    assert sg[w2g].max() > 5.0
    assert np.sqrt(np.mean(eg[w2g] ** 2)) > np.sqrt(np.mean(et[w2t] ** 2))


def _kept_prn(session: Session, t: float) -> int:
    """The highest satellite of the tag at epoch t (kept by any satellite masking)."""
    ep = prepare(session.gnss["tag"])
    k = int(np.argmin(np.abs(ep.time_s - t)))
    ref = session.reference["tag"].interpolate(np.array([t]))[0]
    m = epoch_model(ep, k, local_frame(session.origin_llh), ref, np.zeros(3))
    return int(m.prn[np.argmax(m.el)])


@pytest.mark.parametrize("robust", [True, False])
def test_robust_filter_keeps_a_20_m_pseudorange_error_out(session: Session, robust: bool) -> None:
    t_err = float(session.gnss["tag"].epoch_time_s[5])
    prn = _kept_prn(session, t_err)
    params = GnssParams(max_satellites=5)
    hit = GnssParams(max_satellites=5, gross=(GrossError(t_err, prn, 20.0),))
    base, _ = solve(session, session.ranges.frame, params, uwb=False, robust=robust)
    moved, _ = solve(session, session.ranges.frame, hit, uwb=False, robust=robust)
    a, b = np.asarray(base["tag"].state), np.asarray(moved["tag"].state)
    shift = float(np.linalg.norm(b[:, :3] - a[:, :3], axis=1).max())
    if robust:
        assert shift < 1.0
    else:  # the standard KF takes it: several metres
        assert shift > 3.0


def test_satellite_masking_and_dop(session: Session) -> None:
    params = GnssParams(mask=(MaskWindow(float(session.gnss["tag"].epoch_time_s[3]), 1e12, 4),))
    out, dop = solve(session, session.ranges.frame, params, uwb=True, robust=True, with_dop=True)
    assert dop is not None
    n = np.asarray(out["tag"].n_sat)
    assert n.max() == 10 and n[-1] <= 4
    tag = dop[dop["platform"] == "tag"]
    both = np.isfinite(tag["pdop_gnss"]) & np.isfinite(tag["pdop_uwb"])
    # ranges only add information: the PDOP with UWB never exceeds the GPS-only one
    assert (tag["pdop_uwb"][both] <= tag["pdop_gnss"][both] + 1e-9).all()
    few = (tag["satellites"] < 4) & (tag["uwb_links"] >= 3)
    assert few.any() and np.isfinite(tag["pdop_uwb"][few]).all()
    assert tag["pdop_gnss"][few].isna().all()


def test_pdop_known_geometry() -> None:
    # four satellites: zenith and three at 0 deg elevation 120 deg apart
    el = np.radians([90.0, 0.0, 0.0, 0.0])
    az = np.radians([0.0, 0.0, 120.0, 240.0])
    los = np.column_stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    # G^T G = diag(1.5, 1.5, ., .) horizontally; up and clock: [[1, -1], [-1, 4]]
    expected = np.sqrt(2 / 1.5 + 4 / 3)
    assert pdop(los) == pytest.approx(expected, rel=1e-9)
    assert np.isnan(pdop(los[:3]))
    assert pdop(los[:3], np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])) < 10.0


def test_params_and_filetrack_errors(tmp_path: Path, session: Session) -> None:
    with pytest.raises(ValueError, match="unknown method"):
        GnssParams(methods=("tight", "ppp"))
    with pytest.raises(ValueError, match="k0 < k1"):
        GnssParams(k0=4.0, k1=3.0)
    # observations without a navigation file: one line naming the file
    root = session.root
    copy = tmp_path / "copy"
    copy.mkdir()
    for f in root.iterdir():
        if f.is_file() and f.name != "nav.rnx":
            (copy / f.name).write_bytes(f.read_bytes())
    with pytest.raises(InputError, match="without a navigation file") as err:
        read_session(copy)
    assert "obs_" in str(err.value) and "\n" not in str(err.value)
    (copy / "nav.rnx").write_bytes((root / "nav.rnx").read_bytes())
    (copy / "obs_tag.rnx").write_text("time\n")  # not RINEX: the reader's one line
    with pytest.raises(InputError) as err:
        read_session(copy)
    assert "obs_tag.rnx" in str(err.value) and "\n" not in str(err.value)
    (copy / "obs_tag.rnx").write_bytes((root / "obs_tag.rnx").read_bytes())
    (copy / "obs_ZZ.rnx").write_bytes((root / "obs_tag.rnx").read_bytes())
    with pytest.raises(InputError, match="platform ZZ, which the session does not have"):
        read_session(copy)
