"""imu_<ID>.csv: both forms read into rates, and one clear line for every bad file."""

from __future__ import annotations

import gzip
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.errors import InputError
from coopproc.frames import EARTH_RATE_RADPS
from coopproc.io.imu_csv import find_imu_files, imu_platform, read_imu_csv

FS = 100.0
T0 = 432000.0


def samples(n: int = 1200, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A unit at rest, z up: gyro noise 1e-3 rad/s + a small bias, accel noise 0.01 m/s^2."""
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(n) / FS
    gyro = rng.normal(0.0, 1e-3, (n, 3)) + np.array([2e-4, -1e-4, 3e-4])
    accel = rng.normal(0.0, 0.01, (n, 3)) + np.array([0.05, -0.02, 9.80665])
    return t, gyro, accel


def rate_frame(t: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> pd.DataFrame:
    cols = {"time": t}
    cols |= {f"gyro_{a}": gyro[:, i] for i, a in enumerate("xyz")}
    cols |= {f"accel_{a}": accel[:, i] for i, a in enumerate("xyz")}
    return pd.DataFrame(cols)


def write(frame: pd.DataFrame, path: Path) -> Path:
    frame.to_csv(path, index=False, float_format="%.10f")
    return path


def test_rate_form(tmp_path: Path) -> None:
    t, gyro, accel = samples()
    imu = read_imu_csv(write(rate_frame(t, gyro, accel), tmp_path / "imu_tb3.csv"))
    assert imu.platform == "tb3" and imu.form == "rate"
    np.testing.assert_allclose(imu.time_s, t, atol=1e-9)
    np.testing.assert_allclose(imu.gyro_radps, gyro, atol=1e-9)
    np.testing.assert_allclose(imu.accel_mps2, accel, atol=1e-9)
    assert imu.rate_hz == pytest.approx(100.0, rel=1e-6)
    assert imu.duration_s == pytest.approx(11.99, abs=1e-6)
    assert imu.static_fraction == 1.0 and imu.gaps() == 0 and imu.notes == ()


def test_increment_form_is_divided_by_the_nominal_interval(tmp_path: Path) -> None:
    t, gyro, accel = samples()
    t = t + np.random.default_rng(3).uniform(-1e-4, 1e-4, t.size)  # logging jitter
    frame = pd.DataFrame({"time": t, "temperature": 31.5})
    for i, a in enumerate("xyz"):
        frame[f"dtheta_{a}"] = gyro[:, i] * 0.01
        frame[f"dvel_{a}"] = accel[:, i] * 0.01
    path = tmp_path / "imu_A.csv.gz"
    with gzip.open(path, "wt") as fh:
        frame.to_csv(fh, index=False, float_format="%.12f")
    imu = read_imu_csv(path)
    assert imu.form == "increment" and imu.platform == "A"
    interval = float(np.median(np.diff(t)))  # the nominal interval, not each jittered one
    np.testing.assert_allclose(imu.gyro_radps, gyro * 0.01 / interval, atol=1e-9)
    np.testing.assert_allclose(imu.accel_mps2, accel * 0.01 / interval, atol=1e-7)
    assert imu.notes == (f"{path}: columns temperature ignored",)


def test_gaps_and_motion_are_noted(tmp_path: Path) -> None:
    t, gyro, accel = samples(n=3000)
    keep = np.r_[0:1000, 1100:3000]  # a 1-s gap
    accel = accel.copy()
    accel[1500:, 0] += 2.0 * np.sin(np.arange(1500) / 10.0)  # moving: not at rest
    imu = read_imu_csv(write(rate_frame(t[keep], gyro[keep], accel[keep]), tmp_path / "imu_B.csv"))
    assert imu.gaps() == 1
    assert imu.notes[-1].endswith("1 gap(s) over 0.025 s between samples")
    assert imu.static_fraction == pytest.approx(14 / 29)  # windows 0..13 of 29 at rest


def test_earth_rate_in_deg_per_s_is_noted(tmp_path: Path) -> None:
    t, _, accel = samples()
    gyro = np.tile(np.degrees([EARTH_RATE_RADPS * 0.6, 0.0, EARTH_RATE_RADPS * 0.8]), (t.size, 1))
    imu = read_imu_csv(write(rate_frame(t, gyro, accel), tmp_path / "imu_nav.csv"))
    assert len(imu.notes) == 1 and "57 x the earth rate" in imu.notes[0]


def test_find_files_and_platform(tmp_path: Path) -> None:
    for name in ("imu_B.csv", "imu_A.csv.gz", "imu_.csv", "odo_A.csv", "imu_C.txt"):
        (tmp_path / name).write_text("")
    assert find_imu_files(tmp_path) == {"A": tmp_path / "imu_A.csv.gz", "B": tmp_path / "imu_B.csv"}
    assert imu_platform(Path("x/imu_uav-3.csv")) == "uav-3"
    assert imu_platform(Path("x/static_test.csv")) == "static_test"


def _bad_cases() -> list[tuple[str, Callable[[pd.DataFrame], pd.DataFrame], str]]:
    def drop(col: str) -> Callable[[pd.DataFrame], pd.DataFrame]:
        return lambda f: f.drop(columns=[col])

    def scale(cols: str, k: float) -> Callable[[pd.DataFrame], pd.DataFrame]:
        return lambda f: f.assign(**{c: f[c] * k for c in cols.split()})

    def cell(row: int, col: str, value: float) -> Callable[[pd.DataFrame], pd.DataFrame]:
        def edit(f: pd.DataFrame) -> pd.DataFrame:
            f = f.copy()
            f.loc[row, col] = value
            return f

        return edit

    acc = "accel_x accel_y accel_z"
    gyr = "gyro_x gyro_y gyro_z"
    return [
        ("missing", drop("gyro_y"), ": missing column 'gyro_y'; found time, gyro_x, gyro_z"),
        ("misspelled", lambda f: f.rename(columns={"accel_z": "acel_z"}),
         ": unknown column 'acel_z' (did you mean 'accel_z'?)"),
        ("both", lambda f: f.assign(dtheta_x=0.0),
         ": holds rate columns (gyro_x, gyro_y, gyro_z, accel_x, accel_y, accel_z) and increment"),
        ("back", cell(100, "time", T0 + 0.985),
         ":102: time 432000.985 is not after the previous sample's 432000.99; expected strictly"),
        ("nan", cell(40, "gyro_z", float("nan")),
         ":42: column 'gyro_z': empty or NaN, expected a number"),
        ("slow", lambda f: f.iloc[::10].reset_index(drop=True),
         ": samples 0.1 apart (median), 10 Hz; expected 50-1000 Hz (DATA.md imu_<ID>.csv)"),
        ("ms", lambda f: f.assign(time=f["time"] * 1000.0),
         ": samples 10 apart (median), 0.1 Hz: times look like milliseconds; divide the times"),
        ("g", scale(acc, 1 / 9.80665),
         ": accelerations look like g (median magnitude 1.000; expected specific force"),
        ("mg", scale(acc, 1000 / 9.80665), ": accelerations look like mg (median magnitude"),
        ("no gravity", lambda f: f.assign(accel_z=f["accel_z"] - 9.80665),
         ": accelerations: median magnitude 0.0558 m/s^2, as if gravity were removed; expected"),
        ("deg/s", lambda f: scale(gyr, 180 / math.pi)(f.assign(gyro_x=f["gyro_x"] + 0.01)),
         ": gyro rates at rest (accelerometers steady in 12 1-s windows) read 0.5872 about a "
         "horizontal axis: a real turn that fast would tilt gravity by 33.6 deg per second; the "
         "values look like deg/s; multiply by pi/180"),
        ("full scale", lambda f: f.assign(gyro_z=f["gyro_z"] + 50.0),
         ": gyro rates up to 50 (99.9th percentile of the magnitude; above 34.9 rad/s"),
    ]  # fmt: skip


@pytest.mark.parametrize("case", _bad_cases(), ids=lambda c: c[0])
def test_bad_files_are_one_line(
    tmp_path: Path, case: tuple[str, Callable[[pd.DataFrame], pd.DataFrame], str]
) -> None:
    _, mutate, expected = case
    t, gyro, accel = samples()
    path = write(mutate(rate_frame(t, gyro, accel)), tmp_path / "imu_A.csv")
    with pytest.raises(InputError) as err:
        read_imu_csv(path)
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith(f"{path}{expected}"), text


def test_deg_per_s_needs_a_horizontal_turn_at_rest(tmp_path: Path) -> None:
    """A steady yaw (about gravity) at 0.5 rad/s is a real turn, not a unit error."""
    t, gyro, accel = samples()
    gyro = gyro.copy()
    gyro[:, 2] += 0.5
    assert read_imu_csv(write(rate_frame(t, gyro, accel), tmp_path / "imu_A.csv")).form == "rate"


def test_missing_and_empty_files(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"imu_X\.csv: no such file"):
        read_imu_csv(tmp_path / "imu_X.csv")
    path = tmp_path / "imu_A.csv"
    path.write_text("time,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n")
    with pytest.raises(InputError, match=r"0 data row\(s\); expected IMU samples at 50-1000 Hz"):
        read_imu_csv(path)


def test_frame_convention_from_a_static_start(tmp_path: Path) -> None:
    from coopproc.io.imu_csv import frame_problem, rest_gravity

    t, gyro, accel = samples()
    good = read_imu_csv(write(rate_frame(t, gyro, accel), tmp_path / "imu_A.csv"))
    assert frame_problem(good) == ""
    g = rest_gravity(good)
    assert g is not None and g[2] == pytest.approx(9.80665, abs=0.01)
    frd = accel * np.array([1.0, -1.0, -1.0])  # x forward, y right, z down
    down = read_imu_csv(write(rate_frame(t, gyro, frd), tmp_path / "imu_B.csv"))
    assert "gravity along -z, a z-down body frame" in frame_problem(down)
    side = accel[:, [2, 1, 0]]  # gravity on x: mounted on its side
    assert "gravity along +x" in frame_problem(
        read_imu_csv(write(rate_frame(t, gyro, side), tmp_path / "imu_C.csv"))
    )
