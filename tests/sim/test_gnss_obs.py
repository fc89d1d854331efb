"""Simulated GPS observations (issue 13 item 6), checked through the files written.

One 60-s single-auxiliary session (A1 static, T moving) with canyon segments; the
geometry is recomputed here from the written navigation file and the true trajectory.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.errors import ConfigError
from coopproc.frames import ecef2geodetic, enu2ecef, enu2geodetic, geodetic2ecef
from coopproc.gnss.corrections import azel, klobuchar_s, saastamoinen_m
from coopproc.gnss.ephemeris import SPEED_OF_LIGHT, rotate_to_reception, satellite_states
from coopproc.gnss.rinex_nav import read_nav
from coopproc.gnss.rinex_obs import read_obs
from coopproc.gnss.rinex_write import L1_WAVELENGTH_M, write_nav
from coopproc.io.rtklib_pos import read_pos
from coopproc.sim import Simulation, simulate, write_simulation
from coopproc.sim.gnss_obs import default_nav_path

pytestmark = pytest.mark.skipif(
    not default_nav_path().exists(), reason="shared/data/gnss is not present"
)
SETTINGS = {
    "gnss_multipath_m": 0.4,
    "gnss_multipath_tau_s": 1.0,
    "gnss_tropo_error": 0.1,
    "gnss_iono_error": 0.3,
    "canyon": [[20.0, 30.0, 3], [40.0, 45.0, 1, "T"], [50.0, 55.0, 4]],
}


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    sim = simulate(
        "single-auxiliary", seed=3, duration_s=60, platforms=2, aux_static=True,
        gnss_obs=True, **SETTINGS,
    )  # fmt: skip
    out = tmp_path_factory.mktemp("gnss") / "sim"
    write_simulation(sim, out)
    return out


def _long(path: Path) -> pd.DataFrame:
    obs = read_obs(path)
    return pd.DataFrame(
        {
            "gpst": obs.epoch_gpst_s[obs.epoch_index],
            "prn": obs.prn,
            **{k: obs.values[k] for k in ("C1C", "L1C", "D1C", "S1C")},
        }
    )


def _truth(session: Path, pid: str) -> pd.DataFrame:
    """The observations of ``pid`` joined to their truth terms and clock."""
    toml = (session / "truth" / "params.toml").read_text()
    week = int(toml.split("gps_week = ")[1].split()[0])
    obs = _long(session / f"obs_{pid}.rnx")
    obs["time"] = np.round(obs["gpst"] - week * 604800.0, 6)
    terms = pd.read_csv(session / "truth" / "gnss_errors.csv")
    clock = pd.read_csv(session / "truth" / "gnss_clock.csv")
    terms = terms[terms.platform == pid].merge(clock, on=["time", "platform"])
    terms["time"] = np.round(terms["time"], 6)
    return obs.merge(terms, on=["time", "prn"], validate="one_to_one")


def test_terms_add_up_to_the_written_pseudoranges(session: Path) -> None:
    for pid in ("A1", "T"):
        d = _truth(session, pid)
        assert len(d) == len(pd.read_csv(session / "truth" / "gnss_errors.csv").query(
            "platform == @pid"))  # fmt: skip
        total = (
            d["range"] + d["clock_bias_m"] - d["sat_clock"] + d["tropo"]
            + d["iono"] + d["multipath"] + d["noise"]
        )  # fmt: skip
        np.testing.assert_allclose(d["C1C"], total, atol=6e-4)


def test_range_and_delays_from_the_navigation_file_and_the_truth(session: Path) -> None:
    """Geometric range with Sagnac, satellite clock, Saastamoinen and Klobuchar recomputed
    from nav.rnx and truth/traj_A1.csv: the truth terms are those models, the errors are
    truth = model (1 + e) with one e_T per session and one e_I per satellite."""
    eph = read_nav(session / "nav.rnx")
    d = _truth(session, "A1")
    origin = tuple(float(v) for v in _origin(session))
    traj = pd.read_csv(session / "truth" / "traj_A1.csv")
    r = enu2ecef(traj[["east", "north", "up"]].to_numpy()[:1], origin)[0]
    t_true = d["gpst"].to_numpy() - d["clock_bias_m"].to_numpy() / SPEED_OF_LIGHT
    prn = d["prn"].to_numpy()
    tau = np.full(len(d), 0.07)
    for _ in range(4):
        st = satellite_states(eph, prn, t_true - tau)
        sat = rotate_to_reception(st.pos_ecef_m, tau)
        rho = np.linalg.norm(sat - r, axis=1)
        tau = rho / SPEED_OF_LIGHT
    np.testing.assert_allclose(d["range"], rho, atol=1e-3)
    np.testing.assert_allclose(d["sat_clock"], SPEED_OF_LIGHT * st.clock_l1_s, atol=1e-4)
    az, el = azel(r, sat)
    lat, lon = np.radians(origin[0]), np.radians(origin[1])
    np.testing.assert_allclose(d["elevation_deg"], np.degrees(el), atol=1e-3)
    assert d["elevation_deg"].min() >= 10.0
    tropo = saastamoinen_m(lat, origin[2] + traj["up"].iloc[0], el)
    e_t = d["tropo"] / tropo - 1.0
    assert e_t.std() < 1e-6 and 0 < abs(e_t.mean()) < 0.5  # one draw of N(0, 0.1)
    assert eph.iono_alpha is not None and eph.iono_beta is not None
    iono = np.array([
        klobuchar_s(t, lat, lon, np.array([a]), np.array([e]), eph.iono_alpha, eph.iono_beta)[0]
        for t, a, e in zip(t_true, az, el, strict=True)
    ]) * SPEED_OF_LIGHT  # fmt: skip
    e_i = (d["iono"] / iono - 1.0).groupby(d["prn"])
    assert e_i.std().max() < 1e-4  # constant per satellite
    assert 0.1 < e_i.mean().std() < 0.6  # N(0, 0.3) over ~10 satellites


def _origin(session: Path) -> list[float]:
    text = (session / "session.toml").read_text()
    block = text.split("origin = [")[1].split("]")[0]
    return [float(v) for v in block.replace("\n", " ").split(",") if v.strip()]


def test_noise_and_multipath_have_the_configured_statistics(session: Path) -> None:
    d = pd.concat([_truth(session, pid) for pid in ("A1", "T")])
    scale = 10.0 ** ((45.0 - d["S1C"]) / 20.0)
    z_noise = d["noise"] / (0.5 * scale)  # gnss_code_sigma_m default 0.5 at 45 dB-Hz
    z_mp = d["multipath"] * np.sin(np.radians(d["elevation_deg"])) / 0.4
    n = len(d)
    assert n > 800
    assert abs(z_noise.mean()) < 4 / np.sqrt(n) and 0.92 < z_noise.std() < 1.08
    assert abs(z_mp.mean()) < 0.15 and 0.85 < z_mp.std() < 1.15
    # C/N0 = 32 + 16 sin(el) + N(0, 1)
    cn0_res = d["S1C"] - 32.0 - 16.0 * np.sin(np.radians(d["elevation_deg"]))
    assert abs(cn0_res.mean()) < 0.15 and 0.9 < cn0_res.std() < 1.1


def test_doppler_and_carrier_follow_the_range(session: Path) -> None:
    d = _truth(session, "T").sort_values(["prn", "time"])
    g = d.groupby("prn")
    dt = g["time"].shift(-1) - g["time"].shift(1)
    rate = (g["range"].shift(-1) - g["range"].shift(1)) / dt
    sat_drift = (g["sat_clock"].shift(-1) - g["sat_clock"].shift(1)) / dt
    expected = -(rate + d["clock_drift_mps"] - sat_drift) / L1_WAVELENGTH_M
    scale = 10.0 ** ((45.0 - d["S1C"]) / 20.0)
    z = ((d["D1C"] - expected) / (0.1 * scale))[dt == 2.0]  # 0.1 Hz at 45 dB-Hz
    # the truth's orbit jumps where the nearest ephemeris record changes: the 2-s
    # difference across such a change is not the rate; those few epochs are left out
    jump = z.abs() > 6
    assert jump.sum() <= 4
    z = z[~jump]
    assert len(z) > 300
    assert abs(z.mean()) < 4 / np.sqrt(len(z)) and 0.9 < z.std() < 1.1
    # carrier (m) minus code = -2 iono - multipath - noise + ambiguity: constant per arc
    # up to the code errors
    diff = d["L1C"] * L1_WAVELENGTH_M - d["C1C"] + 2 * d["iono"] + d["multipath"] + d["noise"]
    arc_spread = diff.groupby(d["prn"]).std()
    assert arc_spread.max() < 0.05 or (arc_spread > 1e3).any()  # new arcs: new ambiguity


def test_canyon_leaves_exactly_the_configured_satellites(session: Path) -> None:
    toml = (session / "truth" / "params.toml").read_text()
    start = float(toml.split("start_tow_s = ")[1].split()[0])
    for pid in ("A1", "T"):
        d = _long(session / f"obs_{pid}.rnx")
        counts = d.groupby("gpst").size()
        rel = np.round(counts.index.to_numpy() % 604800.0 - start, 6)
        counts = pd.Series(counts.to_numpy(), index=rel)
        assert len(counts) == 61  # every epoch written
        assert (counts.loc[20.0:30.0] == 3).all() and (counts.loc[50.0:55.0] == 4).all()
        if pid == "T":
            assert (counts.loc[40.0:45.0] == 1).all()
        outside = counts.drop(counts.loc[20.0:30.0].index).drop(counts.loc[50.0:55.0].index)
        if pid == "T":
            outside = outside.drop(outside.loc[40.0:45.0].index)
        assert outside.min() >= 6


def test_spp_on_the_static_receiver(session: Path, tmp_path: Path) -> None:
    """coopproc spp on the static A1: within a few metres of its truth (iono 30 % of
    Klobuchar left, tropo 10 %, multipath, noise)."""
    out = tmp_path / "a1.pos"
    result = CliRunner().invoke(
        main,
        ["spp", str(session / "obs_A1.rnx"), "--nav", str(session / "nav.rnx"),
         "-o", str(out), "--quiet"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    pos = read_pos(out, "A1")
    assert pos.form == "llh"
    assert len(pos.time_s) == 61 - 11  # the canyon epochs (3 satellites) have no solution
    origin = tuple(_origin(session))
    traj = pd.read_csv(session / "truth" / "traj_A1.csv")
    truth = enu2ecef(traj[["east", "north", "up"]].to_numpy()[:1], origin)[0]
    err = np.linalg.norm(geodetic2ecef(pos.position) - truth, axis=1)
    assert np.median(err) < 5.0


def test_off_by_default_and_refused_without_it() -> None:
    assert simulate("single-auxiliary", duration_s=10, platforms=2).gnss is None
    with pytest.raises(ConfigError, match=r"gnss_mask_deg.*does nothing without GNSS"):
        simulate("single-auxiliary", duration_s=10, platforms=2, gnss_mask_deg=5.0)
    with pytest.raises(ConfigError, match="outside the ephemerides"):
        simulate("single-auxiliary", duration_s=10, platforms=2, gnss_obs=True, gps_week=2178)
    with pytest.raises(ConfigError, match="holds no GNSS epoch"):
        simulate(
            "single-auxiliary", duration_s=10, platforms=2, gnss_obs=True, canyon=[[20, 30, 2]]
        )


def test_rinex2_files(tmp_path: Path) -> None:
    sim = simulate(
        "single-auxiliary", duration_s=5, platforms=2, gnss_obs=True, gnss_rinex_version=2
    )
    write_simulation(sim, tmp_path / "s")
    names = sorted(p.name for p in (tmp_path / "s").iterdir())
    assert {"obs_A1.05o", "obs_T.05o", "nav.05n"} <= set(names)
    obs = read_obs(tmp_path / "s" / "obs_T.05o")
    assert obs.version == 2.11 and obs.epoch_gpst_s.size == 6
    table = sim.gnss.observations["T"] if sim.gnss else None
    assert table is not None
    got = np.sort(obs.values["C1"])
    np.testing.assert_allclose(got, np.sort(table.code_m[np.isfinite(table.code_m)]), atol=6e-4)


def _obs_digest(sim: Simulation) -> list[np.ndarray]:
    assert sim.gnss is not None
    out = []
    for _, table in sorted(sim.gnss.observations.items()):
        out += [table.time_gpst_s, table.prn, table.code_m, table.doppler_hz, table.cn0_dbhz]
    return out


_SHORT = {"duration_s": 10.0, "platforms": 2, "gnss_obs": True}
#: every GNSS parameter but gnss_nav, gnss_rinex_version and canyon (tested above)
_ACTS = {
    "gnss_rate_hz": 2.0,
    "gnss_mask_deg": 30.0,
    "gnss_code_sigma_m": 1.0,
    "gnss_doppler_sigma_hz": 0.5,
    "gnss_multipath_m": 1.0,
    "gnss_multipath_tau_s": 5.0,
    "gnss_tropo_error": 0.2,
    "gnss_iono_error": 0.1,
}


def _same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return len(a) == len(b) and all(
        x.shape == y.shape and np.array_equal(x, y, equal_nan=True)
        for x, y in zip(a, b, strict=True)
    )


@functools.cache
def _short_base() -> list[np.ndarray]:
    return _obs_digest(simulate("single-auxiliary", **_SHORT))


@pytest.mark.parametrize("option", sorted(_ACTS))
def test_every_gnss_parameter_acts(option: str) -> None:
    base = _short_base()
    changed = _obs_digest(simulate("single-auxiliary", **_SHORT, **{option: _ACTS[option]}))
    assert not _same(base, changed), option


def test_gnss_nav_flies_the_given_file(tmp_path: Path) -> None:
    eph = read_nav(default_nav_path())
    nav = write_nav(eph.select(eph.prn < 16), tmp_path / "few.rnx")
    sim = simulate("single-auxiliary", **_SHORT, gnss_nav=str(nav))
    assert sim.gnss is not None
    assert sim.gnss.observations["T"].prn.max() < 16
    # the user's file: the session keeps its own origin
    assert sim.truth.params.origin_llh == simulate("single-auxiliary").truth.params.origin_llh


@pytest.mark.parametrize("scenario", ["anchors", "tag-only"])
def test_every_platform_gets_observations(scenario: str) -> None:
    sim = simulate(scenario, duration_s=5.0, gnss_obs=True)
    assert sim.gnss is not None
    assert set(sim.gnss.observations) == set(sim.session.platforms)
    for table in sim.gnss.observations.values():
        assert (np.isfinite(table.code_m).sum(axis=1) >= 5).all()


def test_the_simulated_sky_is_the_real_receivers() -> None:
    """A static receiver simulated at GEONET station 3040 (its header position) over the
    first 20 min of its real file sees exactly the satellites the real receiver recorded
    above 10 deg, and the real minus simulated pseudoranges, less their per-epoch mean (the
    two receiver clocks), scatter by the two files' errors: 1-2 m."""
    real = read_obs(default_nav_path().parent / "30400920.05o")
    station = real.approx_position_ecef_m
    assert station is not None
    llh = ecef2geodetic(station[None, :])[0]
    a1 = simulate("single-auxiliary", duration_s=5, platforms=2, aux_static=True)
    a1_enu = a1.truth.trajectories["A1"].enu_m[0]
    origin = tuple(float(v) for v in enu2geodetic(-a1_enu[None, :], tuple(llh))[0])
    sim = simulate(
        "single-auxiliary", duration_s=1200, platforms=2, aux_static=True, gnss_obs=True,
        gps_week=1316, start_tow_s=518400.0, origin_llh=origin, gnss_rate_hz=0.1,
    )  # fmt: skip
    assert sim.gnss is not None
    sim_obs = sim.gnss.observations["A1"]
    np.testing.assert_allclose(sim_obs.approx_ecef_m, station, atol=1e-3)
    eph = read_nav(default_nav_path().parent / "30400920.05n")
    code = real.code(("C1",))
    spread = []
    for k, t in enumerate(real.epoch_gpst_s):
        i = int(np.argmin(np.abs(sim_obs.time_gpst_s - t)))
        if abs(sim_obs.time_gpst_s[i] - t) > 0.01:  # real epochs drift by milliseconds
            continue
        rows = (real.epoch_index == k) & (real.system == "G")
        prn = real.prn[rows]
        states = satellite_states(eph, prn, np.full(prn.size, t - 0.075))
        above = np.degrees(azel(station, states.pos_ecef_m)[1]) >= 10.0
        seen = np.isfinite(sim_obs.code_m[i])
        assert set(prn[above].tolist()) == set(sim_obs.prn[seen].tolist()), t
        sim_code = dict(zip(sim_obs.prn[seen].tolist(), sim_obs.code_m[i, seen], strict=True))
        diff = np.array(
            [c - sim_code[p] for p, c in zip(prn[above], code[rows][above], strict=True)]
        )
        spread.append(np.std(diff - diff.mean()))
    assert len(spread) == 41  # 0, 30, ..., 1200 s
    assert 0.5 < np.median(spread) < 3.0 and max(spread) < 6.0
