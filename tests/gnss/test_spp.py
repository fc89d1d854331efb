"""Single-point positioning: exact simulated pseudoranges give back the receiver, RAIM
excludes a 60 m fault, the .pos file reads back, and the accuracy on the real GEONET
files (0759 and 3040, 2005 day 092) against their header positions."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from coopproc import frames
from coopproc.cli import main
from coopproc.errors import InputError
from coopproc.gnss.corrections import azel
from coopproc.gnss.ephemeris import (
    OMEGA_E_DOT,
    SPEED_OF_LIGHT,
    GpsEphemerides,
    rotate_to_reception,
    satellite_states,
)
from coopproc.gnss.pos_write import write_spp_pos
from coopproc.gnss.rinex_nav import read_nav
from coopproc.gnss.rinex_obs import GnssObservations, read_obs
from coopproc.gnss.spp import SppOptions, solve_spp
from coopproc.io.rtklib_pos import read_pos

GNSS = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "gnss"
TOE = 1316 * 604800.0 + 525600.0
RECEIVER = frames.geodetic2ecef([[35.16, 139.61, 70.0]])[0]
CLOCK_S = 1.0e-4


def constellation() -> GpsEphemerides:
    """36 satellites, 6 planes x 6 slots, on the orbit of a real GPS ephemeris."""
    n = 36
    plane, slot = np.divmod(np.arange(n), 6)
    z = np.zeros(n)
    return GpsEphemerides(
        prn=np.arange(1, n + 1),
        toc_gpst_s=z + TOE,
        toe_gpst_s=z + TOE,
        af0=1e-5 * (np.arange(n) - 18),
        af1=z + 1e-12,
        af2=z,
        sqrt_a=z + 5153.6,
        e=z + 0.006,
        i0=z + 0.96,
        omega0=plane * np.pi / 3,
        omega=z - 1.65,
        m0=slot * np.pi / 3 + plane * 0.4,
        delta_n=z + 4.0e-9,
        idot=z,
        omega_dot=z - 7.9e-9,
        cuc=z,
        cus=z,
        crc=z,
        crs=z,
        cic=z,
        cis=z,
        tgd=z - 4e-9,
        iode=np.arange(n),
        week=z.astype(np.int64) + 1316,
        health=z.astype(np.int64),
        fit_interval_h=z + 4.0,
    )


def simulate(eph: GpsEphemerides, epochs: int, fault: tuple[int, float] | None = None):
    """Exact L1 pseudoranges (no atmosphere) of the receiver above 15 deg elevation."""
    t_true = TOE + 30.0 * np.arange(epochs)
    rows: list[tuple[int, int, float]] = []
    for k, t in enumerate(t_true):
        prn = eph.prn
        tau = np.full(prn.size, 0.075)
        for _ in range(5):  # light time: the position at t - tau seen at reception
            s = satellite_states(eph, prn, t - tau)
            sat = rotate_to_reception(s.pos_ecef_m, tau)
            tau = np.linalg.norm(sat - RECEIVER, axis=1) / SPEED_OF_LIGHT
        _, el = azel(RECEIVER, sat)
        code = SPEED_OF_LIGHT * (tau + CLOCK_S - s.clock_l1_s)
        for j in np.flatnonzero(el > np.radians(15.0)):
            extra = fault[1] if fault is not None and fault[0] == prn[j] and k == 1 else 0.0
            rows.append((k, int(prn[j]), float(code[j] + extra)))
    r = np.array(rows)
    return GnssObservations(
        epoch_gpst_s=t_true + CLOCK_S,
        epoch_index=r[:, 0].astype(np.int64),
        system=np.full(len(rows), "G"),
        prn=r[:, 1].astype(np.int64),
        values={"C1": r[:, 2]},
        types={"G": ("C1",)},
        line=np.arange(len(rows), dtype=np.int64) + 10,
        version=2.1,
        source="sim.05o",
    )


EXACT = SppOptions(iono=False, tropo=False)


def test_exact_pseudoranges_give_back_the_receiver_and_clock() -> None:
    eph = constellation()
    obs = simulate(eph, 3)
    sol = solve_spp(obs, eph, EXACT)
    assert sol.epochs == 3 and sol.time_gpst_s.size == 3
    assert np.all(sol.n_sat >= 6)
    np.testing.assert_allclose(sol.ecef_m, np.tile(RECEIVER, (3, 1)), atol=0.01)
    np.testing.assert_allclose(sol.clock_m, SPEED_OF_LIGHT * CLOCK_S, atol=0.01)
    # the solution time is the receiver epoch corrected by its clock: the true time
    np.testing.assert_allclose(sol.time_gpst_s, TOE + 30.0 * np.arange(3), atol=1e-9)


def test_earth_rotation_matters() -> None:
    """Without the Sagnac term the solution would be ~10-30 m off: a check that it is in."""
    eph = constellation()
    obs = simulate(eph, 1)
    sol = solve_spp(obs, eph, EXACT)
    assert np.linalg.norm(sol.ecef_m[0] - RECEIVER) < 0.01
    assert OMEGA_E_DOT * np.linalg.norm(RECEIVER) * 0.075 > 10.0  # size of what is modelled


def test_raim_excludes_a_faulty_satellite() -> None:
    eph = constellation()
    clean = simulate(eph, 3)
    faulty_prn = int(clean.prn[clean.epoch_index == 1][0])
    obs = simulate(eph, 3, fault=(faulty_prn, 60.0))
    plain = solve_spp(obs, eph, EXACT)
    moved = np.linalg.norm(plain.ecef_m[1] - RECEIVER)
    assert moved > 5.0
    raim = solve_spp(obs, eph, replace(EXACT, raim=True))
    assert raim.excluded == [(float(obs.epoch_gpst_s[1]), faulty_prn)]
    np.testing.assert_allclose(raim.ecef_m, np.tile(RECEIVER, (3, 1)), atol=0.01)
    assert raim.n_sat[1] == plain.n_sat[1] - 1


def test_elevation_mask_drops_low_satellites() -> None:
    eph = constellation()
    obs = simulate(eph, 1)
    low = solve_spp(obs, eph, replace(EXACT, elevation_mask_deg=0.0))
    high = solve_spp(obs, eph, replace(EXACT, elevation_mask_deg=20.0))
    assert high.n_sat[0] < low.n_sat[0]


def test_times_outside_the_ephemerides_are_a_one_line_error() -> None:
    eph = constellation()
    obs = simulate(eph, 2)
    late = replace(obs, epoch_gpst_s=obs.epoch_gpst_s + 3 * 3600.0)
    with pytest.raises(InputError, match=r"sim\.05o:10: epoch 2005-04-02 05:00:00 GPST \(2 of 2"):
        solve_spp(late, eph, EXACT)


def test_pos_file_reads_back(tmp_path: Path) -> None:
    eph = constellation()
    sol = solve_spp(simulate(eph, 3), eph, EXACT)
    path = write_spp_pos(tmp_path / "a.pos", sol, ["test"])
    back = read_pos(path, "A")
    np.testing.assert_allclose(back.time_s, sol.time_gpst_s, atol=5e-4)
    np.testing.assert_array_equal(back.quality, [5, 5, 5])
    ecef = frames.geodetic2ecef(back.position)
    np.testing.assert_allclose(ecef, sol.ecef_m, atol=1e-3)
    assert back.sigma_enu_m is not None and np.all(back.sigma_enu_m > 0.1)
    assert "   5 " in path.read_text().splitlines()[-1]


# --- the real GEONET files -----------------------------------------------------------


def _real(station: str) -> tuple[Path, Path]:
    obs, nav = GNSS / f"{station}0920.05o", GNSS / f"{station}0920.05n"
    if not (obs.is_file() and nav.is_file()):
        pytest.skip("shared/data/gnss is not present")
    return obs, nav


def _errors(pos: Path, reference: np.ndarray) -> tuple[float, float]:
    back = read_pos(pos, "R")
    llh = frames.ecef2geodetic(reference[None, :])[0]
    enu = frames.geodetic2enu(back.position, (llh[0], llh[1], llh[2]))
    return (
        float(np.median(np.linalg.norm(enu, axis=1))),
        float(np.median(np.hypot(enu[:, 0], enu[:, 1]))),
    )


@pytest.mark.parametrize("station", ["0759", "3040"])
def test_real_geonet_accuracy_through_the_cli(station: str, tmp_path: Path) -> None:
    obs, nav = _real(station)
    out = tmp_path / f"{station}.pos"
    res = CliRunner().invoke(main, ["spp", str(obs), "--nav", str(nav), "-o", str(out), "--raim"])
    assert res.exit_code == 0, res.output
    assert "120 of 120 epochs solved" in res.output
    reference = read_obs(obs).approx_position_ecef_m
    assert reference is not None
    err_3d, err_h = _errors(out, reference)
    # measured: 0759 1.73 / 1.39 m, 3040 1.69 / 0.67 m (3-D / horizontal)
    assert err_3d <= 5.0 and err_h <= 3.0


def test_real_without_atmosphere_models_is_worse() -> None:
    obs_path, nav_path = _real("0759")
    obs, eph = read_obs(obs_path), read_nav(nav_path)
    assert obs.approx_position_ecef_m is not None
    full = solve_spp(obs, eph)
    bare = solve_spp(obs, eph, SppOptions(iono=False, tropo=False))
    ref = obs.approx_position_ecef_m
    err_full = np.median(np.linalg.norm(full.ecef_m - ref, axis=1))
    err_bare = np.median(np.linalg.norm(bare.ecef_m - ref, axis=1))
    assert err_full < 3.0 < err_bare


def test_cli_one_line_error_for_a_truncated_file(tmp_path: Path) -> None:
    obs, nav = _real("0759")
    cut = tmp_path / "cut.05o"
    cut.write_text("".join(obs.read_text().splitlines(keepends=True)[:21]))
    res = CliRunner().invoke(main, ["spp", str(cut), "--nav", str(nav), "-o", str(tmp_path / "x")])
    assert res.exit_code == 1
    assert res.output.strip().splitlines() == [
        f"error: {cut}:18: truncated: epoch has 3 of 8 satellites complete"
    ]
    assert not (tmp_path / "x").exists()


def test_progress_lines_on_long_files(capsys: pytest.CaptureFixture[str]) -> None:
    from coopproc.cli.spp import _Progress

    progress = _Progress(True)
    progress.bar = False
    for done in range(1, 5001):
        progress(done, 5000)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(" (")[0] for line in lines] == [f"spp: {p}0%" for p in range(1, 10)]
    quiet = _Progress(True)
    quiet.bar = False
    for done in range(1, 121):
        quiet(done, 120)  # a short file: nothing
    assert capsys.readouterr().err == ""


def test_cli_one_line_error_for_a_navigation_file_of_another_day(tmp_path: Path) -> None:
    obs, nav = _real("0759")
    # every record a week later (toc date and toe week)
    text = nav.read_text().replace(" 05  4  2 ", " 05  4  9 ")
    text = text.replace("1.316000000000D+03", "1.317000000000D+03")
    later = tmp_path / "later.05n"
    later.write_text(text)
    res = CliRunner().invoke(
        main, ["spp", str(obs), "--nav", str(later), "-o", str(tmp_path / "x")]
    )
    assert res.exit_code == 1
    (line,) = res.output.strip().splitlines()
    assert line.startswith(f"error: {obs}:18: epoch 2005-04-02 00:00:00 GPST (120 of 120 epochs)")
    assert "outside the ephemerides' validity" in line
