"""odo_<ID>.csv: both forms read (speed; wheel speeds + wheelbase), one clear line per bad file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.errors import InputError
from coopproc.io.odo_csv import find_odo_files, odometer_scale_problem, read_odo_csv

T0 = 432000.0


def write(frame: pd.DataFrame, path: Path) -> Path:
    frame.to_csv(path, index=False, float_format="%.10f")
    return path


def speed_frame(n: int = 500, rate: float = 50.0) -> pd.DataFrame:
    t = T0 + np.arange(n) / rate
    return pd.DataFrame({"time": t, "speed": 1.0 + 0.5 * np.sin(t - T0)})


def test_speed_form_round_trips(tmp_path: Path) -> None:
    frame = speed_frame()
    odo = read_odo_csv(write(frame, tmp_path / "odo_tb3.csv"))
    assert odo.platform == "tb3" and odo.form == "speed" and odo.yaw_rate_radps is None
    np.testing.assert_allclose(odo.time_s, frame["time"], atol=1e-9)
    np.testing.assert_allclose(odo.speed_mps, frame["speed"], atol=1e-9)
    assert odo.rate_hz == pytest.approx(50.0) and odo.gaps() == 0


def test_wheel_form_gives_speed_and_yaw_rate(tmp_path: Path) -> None:
    t = T0 + np.arange(100) / 10.0
    frame = pd.DataFrame({"time": t, "v_left": 0.9, "v_right": 1.1, "temp": 20.0})
    path = write(frame, tmp_path / "odo_C.csv")
    odo = read_odo_csv(path, wheelbase_m=0.4)
    assert odo.form == "wheels" and odo.wheelbase_m == 0.4
    np.testing.assert_allclose(odo.speed_mps, 1.0)
    assert odo.yaw_rate_radps is not None
    np.testing.assert_allclose(odo.yaw_rate_radps, 0.2 / 0.4)  # counter-clockwise: left turn
    assert "temp ignored" in odo.notes[0]
    with pytest.raises(InputError, match=r"odo_C.csv.*wheelbase.*\[platforms.C\]"):
        read_odo_csv(path)


def bad(tmp_path: Path, frame: pd.DataFrame, name: str = "odo_A.csv") -> str:
    with pytest.raises(InputError) as info:
        read_odo_csv(write(frame, tmp_path / name), wheelbase_m=0.5)
    text = str(info.value)
    assert "\n" not in text and name in text
    return text


def test_one_line_errors(tmp_path: Path) -> None:
    f = speed_frame()
    assert "missing column 'speed'" in bad(tmp_path, f.drop(columns="speed"))
    assert "did you mean 'speed'" in bad(tmp_path, f.rename(columns={"speed": "sped"}))
    both = f.assign(v_left=1.0, v_right=1.0)
    assert "one form" in bad(tmp_path, both)
    nan = f.copy()
    nan.loc[7, "speed"] = np.nan
    assert ":9:" in bad(tmp_path, nan) and "NaN" in bad(tmp_path, nan)
    back = f.copy()
    back.loc[10, "time"] = back.loc[8, "time"]
    assert "before the previous" in bad(tmp_path, back) and ":12:" in bad(tmp_path, back)
    dup = f.copy()
    dup.loc[10, "time"] = dup.loc[9, "time"]
    assert "repeats" in bad(tmp_path, dup) and ":12:" in bad(tmp_path, dup)
    ms = f.assign(time=(f["time"] - T0) * 1000.0)
    assert "look like milliseconds" in bad(tmp_path, ms)
    fast = f.assign(time=T0 + np.arange(len(f)) * 0.0004)  # 2500 Hz
    assert "expected 1-1000 Hz" in bad(tmp_path, fast)
    kmh = f.assign(speed=f["speed"] * 3.6 * 40)  # up to 216 m/s as read: km/h of 60 m/s
    assert "look like km/h" in bad(tmp_path, kmh)
    mm = f.assign(speed=f["speed"] * 1000.0)
    assert "look like mm/s" in bad(tmp_path, mm)
    wheels = pd.DataFrame({"time": f["time"], "v_left": 1.0, "v_right": 150.0})
    assert "column 'v_right'" in bad(tmp_path, wheels)


def test_km_per_hour_seen_against_the_navigation(tmp_path: Path) -> None:
    t = T0 + np.arange(600) / 10.0
    odo = read_odo_csv(write(pd.DataFrame({"time": t, "speed": 2.0 * 3.6}), tmp_path / "odo_A.csv"))
    nav_t = T0 + np.arange(61.0)
    nav = np.column_stack([2.0 * (nav_t - T0), np.zeros(61)])
    assert "look like km/h" in odometer_scale_problem(odo, nav_t, nav)
    good = read_odo_csv(write(pd.DataFrame({"time": t, "speed": 2.0}), tmp_path / "odo_B.csv"))
    assert odometer_scale_problem(good, nav_t, nav) == ""


def test_find_odo_files(tmp_path: Path) -> None:
    for name in ("odo_A.csv", "odo_B.csv.gz", "nav_A.csv", "odo_.csv"):
        (tmp_path / name).write_text("time,speed\n")
    assert list(find_odo_files(tmp_path)) == ["A", "B"]


def test_a_platform_standing_still_is_not_judged(tmp_path: Path) -> None:
    t = T0 + np.arange(9000) / 10.0
    odo = read_odo_csv(write(pd.DataFrame({"time": t, "speed": 0.0}), tmp_path / "odo_A.csv"))
    noisy = np.random.default_rng(0).normal(0.0, 0.05, (t.size, 2))  # nav noise: a long path
    assert odometer_scale_problem(odo, t, noisy) == ""
