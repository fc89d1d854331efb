"""Plausibility of navigation and reference (issue 32, deliverables 1 and 5): each case of
the issue on a copy of sample_logs, with its one line; the shared real sessions pass."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.errors import ConfigError, InputError
from coopproc.io import read_session
from coopproc.io.plausible import ROLE_BOUNDS, bounds_of
from coopproc.io.session_platforms import parse_platforms, platform_entry

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample_logs"
REAL = REPO.parent / "shared" / "data" / "real"


@pytest.fixture
def sample(tmp_path: Path) -> Path:
    """A copy of sample_logs without its MCAP and truth (not read by these checks)."""
    shutil.copytree(SAMPLE, tmp_path / "s", ignore=shutil.ignore_patterns("mcap", "truth"))
    return tmp_path / "s"


def _cell(path: Path, line: int, column: str, value: str) -> None:
    lines = path.read_text().splitlines(keepends=True)
    header = lines[0].strip().split(",")
    parts = lines[line - 1].rstrip("\n").split(",")
    parts[header.index(column)] = value
    lines[line - 1] = ",".join(parts) + "\n"
    path.write_text("".join(lines))


def _validate(*args: str) -> tuple[int, list[str]]:
    res = CliRunner().invoke(main, ["validate", *args])
    assert "internal error" not in res.output and "Traceback" not in res.output
    return res.exit_code, res.stdout.splitlines()


def test_positions_in_mm_are_refused_with_the_unit(sample: Path) -> None:
    nav = sample / "nav_A.csv"
    frame = pd.read_csv(nav)
    frame[["east", "north", "up"]] *= 1000.0
    frame.to_csv(nav, index=False, float_format="%.6f")
    code, lines = _validate(str(sample))
    assert code == 1
    assert lines[0].startswith(f"{nav}:2: positions look like millimetres: the ranges fit them ")
    assert lines[0].endswith("read as metres; expected metres: divide the positions by 1000")
    fit = float(lines[0].split("fit them to ")[1].split(" m")[0])
    assert fit < 0.5  # sample_logs' own navigation fits its ranges to ~0.26 m
    # every navigation file in mm: one scale for all, and the [columns.nav.units] fix
    for pid in "BC":
        frame = pd.read_csv(sample / f"nav_{pid}.csv")
        frame[["east", "north", "up"]] *= 1000.0
        frame.to_csv(sample / f"nav_{pid}.csv", index=False, float_format="%.6f")
    code, lines = _validate(str(sample))
    assert code == 1 and len(lines) == 3
    assert all('declare session.toml [columns.nav.units] position = "mm"' in x for x in lines)
    # declared, it reads
    toml = sample / "session.toml"
    toml.write_text(toml.read_text() + '\n[columns.nav.units]\nposition = "mm"\n')
    assert _validate(str(sample))[0] == 0


def test_a_glitched_row_is_excluded_with_a_note_or_refused_strict(sample: Path) -> None:
    nav = sample / "nav_A.csv"
    _cell(nav, 22, "east", "1000000.0")
    code, lines = _validate(str(sample))
    (note,) = [x for x in lines if "single-row glitch" in x]
    assert note.startswith(f"note: {nav}:22: 1 single-row glitch: a row 999,99")
    assert note.endswith(
        " m off its neighbour (a follower's bound is 70 m/s + 5 m per epoch); excluded"
    )
    assert code == 0 and lines[-1] == f"{sample}: ok"
    session = read_session(sample)
    assert len(session.nav["A"]) == 6000 and float(np.abs(session.nav["A"].enu_m).max()) < 500
    assert note.removeprefix("note: ") in session.notes  # run prints it too
    code, lines = _validate("--strict", str(sample))
    assert code == 1 and lines[0].startswith(f"{nav}:22: 1 single-row glitch")
    assert lines[0].endswith("expected a plausible trajectory (--strict)")
    with pytest.raises(InputError) as err:  # what coopproc run --strict ends with
        read_session(sample, strict=True)
    assert str(err.value) == lines[0]


def test_overflowing_cell_is_one_line_not_an_internal_error(sample: Path) -> None:
    nav = sample / "nav_A.csv"
    _cell(nav, 22, "east", "1e300")
    code, lines = _validate(str(sample))
    expected = (
        f"{nav}:22: position 1e+300 m from the session origin is not on the Earth (over "
        "1e+07 m); expected metres (a corrupt or overflowing cell?)"
    )
    assert (code, lines) == (1, [expected])
    res = CliRunner().invoke(main, ["run", str(sample), "-o", str(sample / "out")])
    assert res.exit_code == 1 and res.output.splitlines()[-1] == f"error: {expected}"


def test_a_jump_and_an_override_of_the_bounds(sample: Path) -> None:
    nav = sample / "nav_A.csv"
    frame = pd.read_csv(nav)
    frame.loc[3000:, "east"] += 100.0  # a reset of the frame at line 3002
    frame.to_csv(nav, index=False, float_format="%.6f")
    code, lines = _validate(str(sample))
    warning = [x for x in lines if x.startswith("warning: ")]
    assert code == 0 and len(warning) == 1 and lines[-1] == f"{sample}: ok (1 warning)"
    assert warning[0].startswith(f"warning: {nav}:3002: position jumps 99.95 m in 0.1 s (")
    # the bound overridden in session.toml: A may jump 150 m (max_jump)
    toml = sample / "session.toml"
    text = toml.read_text()
    toml.write_text(text.replace("0.0043\n", "0.0043\nmax_jump = 150.0\n", 1))
    assert not [n for n in read_session(sample).notes if n.startswith("warning: ")]
    # a bound far too tight: sustained, refused (a unit or a scale)
    toml.write_text(text.replace("0.0043\n", "0.0043\nmax_speed = 0.1\nmax_jump = 0.001\n", 1))
    with pytest.raises(InputError, match="implausible speeds: ") as err:
        read_session(sample)
    assert str(err.value).startswith(f"{nav}:")


def test_velocities_in_kmh_are_named(sample: Path) -> None:
    nav = sample / "nav_B.csv"
    frame = pd.read_csv(nav)
    t = frame["time"].to_numpy()
    for axis in ("east", "north", "up"):
        frame[f"vel_{axis}"] = np.gradient(frame[axis].to_numpy(), t) * 3.6
    frame.to_csv(nav, index=False, float_format="%.6f")
    code, lines = _validate(str(sample))
    assert code == 1
    assert lines[0].startswith(f"{nav}:2: velocities look like km/h (their median magnitude ")
    assert lines[0].endswith(
        'divide them by 3.6, or declare session.toml [columns.units] velocity = "km/h"'
    )


def test_bounds_per_role_and_session_toml_keys() -> None:
    (a,) = parse_platforms({"A": {"role": "anchor", "max_speed": 0.5}}, "s").values()
    b = bounds_of(a)
    assert (b.max_speed_mps, b.max_jump_m) == (0.5, ROLE_BOUNDS["anchor"].max_jump_m)
    assert platform_entry(a)["max_speed"] == 0.5
    with pytest.raises(ConfigError, match=r"max_accel: -1\.0; expected a positive bound"):
        parse_platforms({"A": {"max_accel": -1.0}}, "s")


@pytest.mark.skipif(not REAL.exists(), reason="../shared/data/real is absent")
@pytest.mark.parametrize("name", ["hanyang_los", "miluv1", "plaza2", "tiers", "tuc"])
def test_real_sessions_pass_the_default_bounds(name: str) -> None:
    """The bounds were chosen on these: no warning, no glitch, no problem."""
    session = read_session(REAL / name)
    assert not [n for n in session.notes if n.startswith("warning: ")]
    assert not [n for n in session.notes if "glitch" in n]


def test_validate_shows_reader_decisions_and_one_line_per_truncated_line(sample: Path) -> None:
    ranges = sample / "ranges.csv"
    lines = ranges.read_text().splitlines(keepends=True)
    lines[2], lines[3] = lines[3], lines[2]  # out of order
    lines.append(lines[-1])  # a duplicate
    ranges.write_text("".join(lines))
    code, out = _validate(str(sample))
    assert code == 0
    assert f"note: {ranges}: times not in order; rows sorted by time" in out
    assert f"note: {ranges}: 1 duplicated row(s) dropped" in out
    assert (
        f"note: {sample / 'ref_A.pos'}: 101 of 3001 epochs with Q not in [1] dropped from "
        "the reference" in out
    )
    # a truncated last line: one message, not one per empty column
    nav = sample / "nav_C.csv"
    nav.write_text(nav.read_text().rstrip("\n").rsplit("\n", 1)[0] + "\n108600.000000,-7")
    code, out = _validate(str(sample))
    assert (code, out) == (
        1,
        [
            f"{nav}:6002: 6 empty cells (north, up, sigma_east, sigma_north, sigma_up, heading): "
            "a truncated or short line; expected a number in every column"
        ],
    )


def test_ranges_in_cm_get_a_unit_hint(sample: Path) -> None:
    ranges = sample / "ranges.csv"
    frame = pd.read_csv(ranges)
    frame["range"] *= 100.0
    frame.to_csv(ranges, index=False, float_format="%.6f")
    code, out = _validate(str(sample))
    assert (code, out) == (
        1,
        [
            f"{ranges}:2: ranges look like centimetres (median 1,880; 656 of 1764 rows above "
            "2000); expected metres: divide the ranges by 100, or declare session.toml "
            '[columns.units] range = "cm"'
        ],
    )
