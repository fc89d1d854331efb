"""RINEX writers: the fixed columns of the standard, and write -> read -> the same numbers."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from coopproc.gnss.ephemeris import GpsEphemerides
from coopproc.gnss.rinex_nav import read_nav
from coopproc.gnss.rinex_obs import read_obs
from coopproc.gnss.rinex_write import (
    ObsTable,
    gpst_to_calendar,
    nav_text,
    obs_text,
    write_nav,
    write_obs,
)

GNSS = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "gnss"
WEEK = 604800.0
T0 = 1316 * WEEK + 561600.0  # 2005-04-02 12:00:00 GPST


def _obs(n_sats: int = 3, epochs: int = 3) -> ObsTable:
    rng = np.random.default_rng(4)
    shape = (epochs, n_sats)
    code = np.round(rng.uniform(2.0e7, 2.5e7, shape), 3)
    code[min(1, epochs - 1), 0] = np.nan  # satellite 0 not seen at epoch 1
    phase = np.round(code / 0.19029367279836487 + 1234.0, 3)
    doppler = np.where(np.isnan(code), np.nan, np.round(rng.uniform(-4000, 4000, shape), 3))
    cn0 = np.where(np.isnan(code), np.nan, np.round(rng.uniform(30, 50, shape), 3))
    lli = np.zeros(shape, dtype=np.int64)
    lli[2, 0] = 1
    return ObsTable(
        marker="A",
        approx_ecef_m=(-3977238.4350, 3382615.1007, 3651187.8093),
        interval_s=1.0,
        time_gpst_s=T0 + np.arange(epochs, dtype=float),
        prn=np.arange(1, n_sats + 1, dtype=np.int64) * 2,
        code_m=code,
        doppler_hz=doppler,
        cn0_dbhz=cn0,
        phase_cycles=phase,
        lli=lli,
    )


def test_calendar_of_gps_time() -> None:
    assert gpst_to_calendar(T0 + 0.5) == (2005, 4, 2, 12, 0, 0.5)
    assert gpst_to_calendar(0.0) == (1980, 1, 6, 0, 0, 0.0)


def test_obs3_fixed_columns() -> None:
    lines = obs_text(_obs(), 3).splitlines()
    end = lines.index(next(x for x in lines if x[60:] == "END OF HEADER"))
    assert all(len(x) <= 80 for x in lines[: end + 1])
    assert lines[0][60:] == "RINEX VERSION / TYPE" and lines[0][:9] == "     3.04"
    head = {x[60:].strip(): x[:60] for x in lines[:end]}
    assert head["SYS / # / OBS TYPES"].startswith("G    4 C1C L1C D1C S1C")
    assert head["APPROX POSITION XYZ"][:42] == " -3977238.4350  3382615.1007  3651187.8093"
    assert head["TIME OF FIRST OBS"][:43] == "  2005     4     2    12     0    0.0000000"
    assert lines[end + 1] == "> 2005 04 02 12 00  0.0000000  0  3"
    sat = lines[end + 2]
    assert sat[:3] == "G02" and len(sat) <= 3 + 4 * 16
    assert float(sat[3:17]) == _obs().code_m[0, 0]
    # epoch 1: satellite G02 missing, two satellites written
    assert lines[end + 5] == "> 2005 04 02 12 00  1.0000000  0  2"
    assert lines[end + 6][:3] == "G04"
    # epoch 2: LLI 1 on G02's phase (column 3 + 16 + 14)
    row = lines[end + 9]
    assert row[:3] == "G02" and row[3 + 16 + 14] == "1" and row[3 + 14] == " "


def test_obs2_epoch_continuation_lines() -> None:
    text = obs_text(_obs(n_sats=14), 2)
    lines = text.splitlines()
    end = next(i for i, x in enumerate(lines) if x[60:] == "END OF HEADER")
    assert lines[end + 1].startswith(" 05  4  2 12  0  0.0000000  0 14G02G04")
    assert len(lines[end + 1]) == 32 + 12 * 3
    assert lines[end + 2] == " " * 32 + "G26G28"
    assert "     4    C1    L1    D1    S1" in text


@pytest.mark.parametrize("version", [3, 2])
def test_obs_round_trip_through_the_reader(tmp_path: Path, version: int) -> None:
    obs = _obs(n_sats=13)
    path = write_obs(obs, tmp_path / f"obs_A.{'rnx' if version == 3 else '05o'}", version)
    back = read_obs(path)
    assert back.marker == "A" and back.interval_s == 1.0
    np.testing.assert_allclose(back.approx_position_ecef_m, obs.approx_ecef_m, atol=1e-4)
    np.testing.assert_array_equal(back.epoch_gpst_s, obs.time_gpst_s)
    names = ("C1C", "L1C", "D1C", "S1C") if version == 3 else ("C1", "L1", "D1", "S1")
    arrays = (obs.code_m, obs.phase_cycles, obs.doppler_hz, obs.cn0_dbhz)
    for name, arr in zip(names, arrays, strict=True):
        assert arr is not None
        full = np.full(arr.shape, np.nan)
        col = np.searchsorted(obs.prn, back.prn)
        full[back.epoch_index, col] = back.values[name]
        np.testing.assert_allclose(full, arr, atol=5e-4, err_msg=name)


def _ephemerides() -> GpsEphemerides:
    """Two records with IS-GPS-200-like magnitudes (12 significant digits)."""
    arr = lambda *v: np.array(v, dtype=np.float64)  # noqa: E731
    toe = arr(1316 * WEEK + 525600.0, 1317 * WEEK + 0.0)
    return GpsEphemerides(
        prn=np.array([3, 31], dtype=np.int64),
        toc_gpst_s=toe.copy(),
        toe_gpst_s=toe,
        af0=arr(9.67523083091e-05, -3.2540224492550e-06),
        af1=arr(3.06954461848e-12, -1.13686837722e-12),
        af2=arr(0.0, 0.0),
        sqrt_a=arr(5153.73075485, 5153.63647842),
        e=arr(6.73580367584e-03, 1.16839138791e-02),
        i0=arr(0.927432771458, 0.955036233365),
        omega0=arr(0.535433599507, -2.44731467152),
        omega=arr(0.603916517924, -1.80153542373),
        m0=arr(-2.76193404706, 1.23456789012),
        delta_n=arr(5.36522337669e-09, 4.99985084629e-09),
        idot=arr(-1.30362567963e-10, 3.21441960039e-11),
        omega_dot=arr(-8.27677304471e-09, -8.01176515234e-09),
        cuc=arr(9.46223735809e-07, -3.18512320518e-06),
        cus=arr(7.53253698349e-06, 9.31322574615e-06),
        crc=arr(217.34375, 207.15625),
        crs=arr(18.65625, -58.53125),
        cic=arr(-1.49011611938e-08, 1.30385160446e-07),
        cis=arr(-9.49949026108e-08, -2.98023223877e-08),
        tgd=arr(-4.19095158577e-09, -1.30385160446e-08),
        iode=np.array([84, 7], dtype=np.int64),
        week=np.array([1316, 1317], dtype=np.int64),
        health=np.array([0, 0], dtype=np.int64),
        fit_interval_h=arr(4.0, 4.0),
        iono_alpha=(1.118e-08, 1.49e-08, -5.96e-08, -5.96e-08),
        iono_beta=(88060.0, 16380.0, -196600.0, -131100.0),
    )


def _assert_same(a: GpsEphemerides, b: GpsEphemerides) -> None:
    order = np.lexsort((a.prn, a.toc_gpst_s))
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_allclose(y, x[order], rtol=1e-12, atol=0, err_msg=f.name)
        elif f.name != "source":
            assert x == y, f.name


@pytest.mark.parametrize("version", [3, 2])
def test_nav_round_trip_through_the_reader(tmp_path: Path, version: int) -> None:
    eph = _ephemerides()
    back = read_nav(write_nav(eph, tmp_path / f"nav.{'rnx' if version == 3 else '05n'}", version))
    _assert_same(eph, back)  # the week-1317 record with toe 0 keeps its week


def test_nav_fixed_columns() -> None:
    lines = nav_text(_ephemerides(), 3).splitlines()
    assert (
        lines[2] == "GPSA   1.1180E-08  1.4900E-08 -5.9600E-08 -5.9600E-08       IONOSPHERIC CORR"
    )
    first = lines[5]
    assert first.startswith("G03 2005 04 02 02 00 00 9.675230830910E-05")
    assert len(first) == 23 + 3 * 19 and all(len(x) == 4 + 4 * 19 for x in lines[6:12])
    v2 = nav_text(_ephemerides(), 2).splitlines()
    assert v2[2][60:] == "ION ALPHA" and v2[2][:14] == "    1.1180D-08"
    assert v2[5].startswith(" 3 05  4  2  2  0  0.0 9.675230830910D-05")


@pytest.mark.parametrize("version", [3, 2])
def test_real_nav_file_round_trip(tmp_path: Path, version: int) -> None:
    src = GNSS / "07590920.05n"
    if not src.exists():
        pytest.skip("shared/data/gnss is not present")
    eph = read_nav(src)
    _assert_same(eph, read_nav(write_nav(eph, tmp_path / "nav.rnx", version)))
