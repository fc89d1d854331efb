"""Clock offsets (issue 32, deliverable 2): the known answers 18 s, 0.5 s, 50 ms and 0 on
small simulated sessions with noise, through ``coopproc validate`` and ``coopproc run``;
50 ms within 5 ms at 2 cm noise; a motionless session says "not observable"; the
``[time] offsets`` table applied (estimate or per file)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.checks.clock import BOUND_S, estimate_clock, likely_cause
from coopproc.cli import main
from coopproc.errors import ConfigError
from coopproc.io import read_session
from coopproc.io.session_toml import parse_session_toml
from coopproc.sim import simulate, write_simulation
from tests.checks.clock_kit import shift_csv, shift_pos


def _write(root: Path, scenario: str, **overrides: object) -> Path:
    sim = simulate(scenario, seed=3, uwb_noise_m=0.02, imu_rate_hz=0, **overrides)  # type: ignore[arg-type]
    write_simulation(sim, root, force=True)
    shutil.rmtree(root / "truth", ignore_errors=True)
    return root


@pytest.fixture(scope="module")
def car(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """land-vehicle, 90 s: a car at 8 m/s among 6 anchors, 2 cm ranging noise."""
    return _write(tmp_path_factory.mktemp("clock") / "car", "land-vehicle", duration_s=90.0)


@pytest.fixture(scope="module")
def cart(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """anchors, 120 s: a handcart tag at 0.6 m/s among 6 anchors, 2 cm ranging noise."""
    return _write(tmp_path_factory.mktemp("clock") / "cart", "anchors", duration_s=120.0)


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def _validate(path: Path) -> str:
    res = CliRunner().invoke(main, ["validate", str(path)])
    assert res.exit_code == 0, res.output
    return res.output


def _offset(path: Path, key: str) -> tuple[float, float]:
    report = estimate_clock(read_session(path))
    found = next(o for o in report.offsets if o.key == key)
    assert found.offset_s is not None and found.sigma_s is not None, found.why
    return found.offset_s, found.sigma_s


def test_no_offset_reads_zero_and_says_nothing(car: Path) -> None:
    offset, sigma = _offset(car, "nav.car")
    assert abs(offset) < 0.005 and sigma < 0.005
    out = _validate(car)
    assert "clock offset" not in out


def test_50_ms_within_5_ms_at_2_cm_noise(car: Path, tmp_path: Path) -> None:
    """The issue's figure: trajectopy finds -35.5 ms for a true 50 ms at 2 cm noise."""
    path = _copy(car, tmp_path / "late")
    shift_csv(path / "nav_car.csv", 0.050)
    offset, sigma = _offset(path, "nav.car")
    assert offset == pytest.approx(0.050, abs=0.005)
    assert sigma < 0.005 and abs(offset - 0.050) < 4 * sigma + 1e-3
    out = _validate(path)
    line = next(x for x in out.splitlines() if "clock offset" in x)
    assert "car: nav_car.csv runs 0.05" in line and "ahead of ranges.csv" in line
    assert "likely a latency" in line and "[time.offsets] nav.car = 0.05" in line


def test_a_declared_offset_is_subtracted(car: Path, tmp_path: Path) -> None:
    path = _copy(car, tmp_path / "declared")
    shift_csv(path / "nav_car.csv", 0.050)
    with (path / "session.toml").open("a") as f:
        f.write("\n[time.offsets]\nnav.car = 0.05\n")
    out = _validate(path)
    assert "clock offset:" not in out
    assert "note: [time.offsets] nav.car: +0.05 s subtracted" in out
    assert abs(_offset(path, "nav.car")[0]) < 0.005


def test_half_a_second_on_the_reference(cart: Path, tmp_path: Path) -> None:
    path = _copy(cart, tmp_path / "ref")
    shift_pos(path / "ref_tag.pos", 0.5)
    report = estimate_clock(read_session(path))
    ref = next(o for o in report.offsets if o.key == "ref.tag")
    assert ref.against_nav_s == pytest.approx(0.5, abs=0.02)
    assert set(report.corrections) == {"ref.tag"}
    assert report.corrections["ref.tag"] == pytest.approx(0.5, abs=0.02)
    out = _validate(path)
    assert "tag: ref_tag.pos runs 0.5" in out and "ahead of ranges.csv" in out


def test_half_a_second_on_the_navigation(cart: Path, tmp_path: Path) -> None:
    path = _copy(cart, tmp_path / "nav")
    shift_csv(path / "nav_tag.csv", 0.5)
    offset, sigma = _offset(path, "nav.tag")
    assert offset == pytest.approx(0.5, abs=0.02) and sigma < 0.02


def test_18_s_leap_seconds_validate_then_run_applies_the_estimate(
    cart: Path, tmp_path: Path
) -> None:
    """Ranges stamped in UTC against navigation and reference in GPS time."""
    path = _copy(cart, tmp_path / "utc")
    shift_csv(path / "ranges.csv", -18.0)
    out = _validate(path)
    line = next(x for x in out.splitlines() if "clock offset" in x)
    assert "ranges.csv runs 18.0" in line and "behind the navigation" in line
    assert "18 leap seconds between GPS time and UTC" in line
    assert "[time.offsets] ranges = -18" in line
    toml = (path / "session.toml").read_text()
    (path / "session.toml").write_text(toml.replace("[time]\n", '[time]\noffsets = "estimate"\n'))
    out_dir = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(path), "-o", str(out_dir), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert '[time] offsets = "estimate": +' not in res.output
    assert "-18.0" in res.output and "subtracted from the times of ranges.csv" in res.output
    clock = json.loads((out_dir / "run.json").read_text())["clock"]
    assert clock["applied_s"]["ranges"] == pytest.approx(-18.0, abs=0.02)
    assert clock["corrections_s"] == {}  # nothing left off the session clock
    assert all(abs(o["offset_s"]) < BOUND_S for o in clock["offsets"])
    positions = pd.read_csv(out_dir / "positions.csv")
    assert len(positions) > 0


def test_a_motionless_session_is_not_observable(tmp_path: Path) -> None:
    """Nothing moves: no range rate, no offset, "not observable" and no number."""
    rng = np.random.default_rng(1)
    t = 108000.0 + np.arange(0, 120, 0.1)
    nav = pd.DataFrame({"time": t, "east": 1.0, "north": 2.0, "up": 0.0})
    nav[["east", "north"]] += rng.normal(0, 0.005, (t.size, 2))
    nav.to_csv(tmp_path / "nav_A.csv", index=False, float_format="%.6f")
    anchors = {"AN1": (10.0, 0.0, 1.0), "AN2": (0.0, 12.0, 1.0), "AN3": (-8.0, -6.0, 1.0)}
    rows = []
    for tk in 108000.0 + np.arange(0, 120, 1.0):
        for j, (name, pos) in enumerate(anchors.items()):
            d = float(np.linalg.norm(np.subtract(pos, (1.0, 2.0, 0.0))))
            rows.append((tk + 0.02 * j, "A", name, d + rng.normal(0, 0.05)))
    pd.DataFrame(rows, columns=["time", "from", "to", "range"]).to_csv(
        tmp_path / "ranges.csv", index=False, float_format="%.6f"
    )
    toml = '[time]\nbase = "gps_tow"\ngps_week = 2178\n[frame]\norigin = [34.8, 113.6, 100.0]\n'
    for name, pos in anchors.items():
        toml += f'[platforms.{name}]\nrole = "anchor"\nposition = {list(pos)}\n'
    (tmp_path / "session.toml").write_text(toml)
    report = estimate_clock(read_session(tmp_path))
    (nav_a,) = [o for o in report.offsets if o.key == "nav.A"]
    assert nav_a.offset_s is None and "moves" in nav_a.why
    assert report.corrections == {}
    out = _validate(tmp_path)
    assert "A: clock offset of nav_A.csv not observable (its navigation moves 0.0" in out


@pytest.mark.parametrize(
    ("offset", "words"),
    [
        (18.0, "18 leap seconds"),
        (-17.99, "18 leap seconds"),
        (3600.0, "a time zone (1 h"),
        (-7 * 3600.0 + 18, "a time zone (7 h) and the 18 leap seconds"),
        (0.018, "18 ms: the 18 leap seconds applied in milliseconds (x1000)"),
        (7.2, "2 h / 1000"),
        (0.05, "a latency"),
        (5.0, "a whole number of seconds"),
        (123.4, "none of the usual"),
    ],
)
def test_likely_cause(offset: float, words: str) -> None:
    assert words in likely_cause(offset, 0.001)


def test_time_offsets_table_is_checked() -> None:
    base = '[time]\nbase = "gps_tow"\n'
    assert parse_session_toml(base + 'offsets = "estimate"\n').config.time_offsets == "estimate"
    read = parse_session_toml(base + "[time.offsets]\nranges = -18\nnav.A = 0.5\nref.B = 1\n")
    assert read.config.time_offsets == {"ranges": -18.0, "nav.A": 0.5, "ref.B": 1.0}
    with pytest.raises(ConfigError, match=r"\[time\] offsets: 'guess'; expected \"estimate\""):
        parse_session_toml(base + 'offsets = "guess"\n')
    with pytest.raises(ConfigError, match=r"unknown key 'nv' \(did you mean 'nav'\?\)"):
        parse_session_toml(base + "[time.offsets]\nnv.A = 1\n")
    with pytest.raises(ConfigError, match=r"\[time.offsets\] nav.A: 'x'"):
        parse_session_toml(base + '[time.offsets]\nnav.A = "x"\n')
