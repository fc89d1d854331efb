"""Issue 16, item 3: time-base, unit and CSV-layout mistakes get one line naming the cause
and the fix, from ``coopproc validate`` (every problem) and from any command that reads
the session (the first problem, as ``error: ...``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io.timebase import looks_like

_SESSION_FILES = ("nav_A.csv", "nav_B.csv", "nav_C.csv", "ranges.csv")


def _problems(session: Path) -> list[str]:
    """``coopproc validate`` output (exit 1); ``coopproc info`` stops at the first line."""
    runner = CliRunner()
    res = runner.invoke(main, ["validate", str(session)])
    assert res.exit_code == 1, res.output
    lines = res.stdout.splitlines()
    info = runner.invoke(main, ["info", str(session)])
    assert info.exit_code == 1 and info.stdout == ""
    assert info.stderr == f"error: {lines[0]}\n"
    return [line.replace(f"{session}/", "") for line in lines]


def _times(session: Path, change: Callable[[pd.Series], pd.Series], *names: str) -> None:
    for name in names or _SESSION_FILES:
        frame = pd.read_csv(session / name)
        frame["time"] = change(frame["time"])
        frame.to_csv(session / name, index=False, float_format="%.6f")


def _toml(session: Path, old: str, new: str) -> None:
    path = session / "session.toml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


def _pos_date(session: Path, name: str, date: str) -> None:
    path = session / name
    path.write_text(path.read_text().replace("2021/10/08", date))


def test_wrong_gps_week_names_both_weeks_and_session_toml(sample_dir: Path) -> None:
    _toml(sample_dir, "gps_week = 2178", "gps_week = 2179")
    assert _problems(sample_dir) == [
        "session.toml [time] gps_week: 2179, but ref_A.pos, ref_B.pos, ref_C.pos are in "
        "GPS week 2178 (in week 2179 their times fall at -172800.000..-172795.100, outside "
        "the navigation and ranges' 432000.000..432004.900); set gps_week = 2178 in "
        "session.toml"
    ]


def test_gps_week_one_off_still_fits_the_base_but_not_the_session(sample_dir: Path) -> None:
    _toml(sample_dir, "gps_week = 2178", "gps_week = 2177")
    assert _problems(sample_dir) == [
        "session.toml [time] gps_week: 2177, but ref_A.pos, ref_B.pos, ref_C.pos are in "
        "GPS week 2178 (in week 2177 their times fall at 1036800.000..1036804.900, outside "
        "the navigation and ranges' 432000.000..432004.900); set gps_week = 2178 in "
        "session.toml"
    ]


def test_one_pos_file_of_another_week_is_the_file_to_fix(sample_dir: Path) -> None:
    _pos_date(sample_dir, "ref_C.pos", "2021/10/15")
    assert _problems(sample_dir) == [
        "ref_C.pos: epochs in GPS week 2179, but session.toml [time] gps_week is 2178; in "
        "week 2178 its times fall at 1036800.000..1036804.900, outside the navigation and "
        "ranges' 432000.000..432004.900; expected week 2178 like ref_A.pos: check that "
        "ref_C.pos belongs to this session"
    ]


def test_pos_weeks_disagree_without_gps_week(sample_dir: Path) -> None:
    _toml(sample_dir, "gps_week = 2178\n", "")
    _pos_date(sample_dir, "ref_B.pos", "2021/10/15")
    assert _problems(sample_dir) == [
        "ref_B.pos: epochs in GPS week 2179, but the session's week is 2178 (of ref_A.pos; "
        "[time] gps_week not given); in week 2178 its times fall at "
        "1036800.000..1036804.900, outside the navigation and ranges' "
        "432000.000..432004.900; check that ref_B.pos belongs to this session, or give "
        "[time] gps_week"
    ]


def test_unix_milliseconds_are_not_called_unix_seconds(sample_dir: Path) -> None:
    _times(sample_dir, lambda t: (t - 432000.0 + 1633651182.0) * 1000.0)
    _toml(sample_dir, 'base = "gps_tow"\ngps_week = 2178\n', 'base = "unix"\n')
    expected = (
        'look like Unix milliseconds; expected Unix seconds as [time] base = "unix" says: '
        "divide the times by 1000"
    )
    assert _problems(sample_dir) == [
        f"nav_A.csv: times 1633651182000.000..1633651186900.000 {expected}",
        f"nav_B.csv: times 1633651182000.000..1633651186900.000 {expected}",
        f"nav_C.csv: times 1633651182000.000..1633651186900.000 {expected}",
        f"ranges.csv: times 1633651182000.000..1633651186000.000 {expected}",
    ]


def test_milliseconds_of_week_without_a_base(sample_dir: Path) -> None:
    # 4.32e8 would pass for Unix seconds (1983); the 100-apart epochs say milliseconds.
    _times(sample_dir, lambda t: t * 1000.0)
    _toml(sample_dir, 'base = "gps_tow"\n', "")
    expected = (
        "expected GPS seconds of week (0..604800) as inferred from the times ([time] base "
        "not given): divide the times by 1000"
    )
    assert _problems(sample_dir) == [
        "nav_A.csv: times 432000000.000..432004900.000 look like milliseconds (epochs 100 "
        f"apart, median); {expected}",
        "nav_B.csv: times 432000000.000..432004900.000 look like milliseconds (epochs 100 "
        f"apart, median); {expected}",
        "nav_C.csv: times 432000000.000..432004900.000 look like milliseconds (epochs 100 "
        f"apart, median); {expected}",
        "ranges.csv: times 432000000.000..432004000.000 look like milliseconds (epochs 1000 "
        f"apart, median); {expected}",
    ]


def test_relative_milliseconds_are_found_by_their_spacing(sample_dir: Path) -> None:
    # The values fit [time] base = "relative"; only the spacing gives them away.
    _times(sample_dir, lambda t: (t - 432000.0) * 1000.0)
    _toml(sample_dir, 'base = "gps_tow"\ngps_week = 2178\n', 'base = "relative"\n')
    for name in ("ref_A.pos", "ref_B.pos", "ref_C.pos"):
        (sample_dir / name).unlink()
    nav = (
        "epochs 100 apart (median) look like milliseconds (10 Hz); expected seconds "
        "(navigation at 1..100 Hz): divide the times by 1000"
    )
    assert _problems(sample_dir) == [
        f"nav_A.csv: {nav}",
        f"nav_B.csv: {nav}",
        f"nav_C.csv: {nav}",
        "ranges.csv: epochs 1000 apart (median) look like milliseconds (1 Hz); expected "
        "seconds: divide the times by 1000",
    ]


def test_unix_seconds_against_gps_tow_say_which_key_to_change(sample_dir: Path) -> None:
    _times(sample_dir, lambda t: t - 432000.0 + 1633651182.0)
    expected = (
        "look like Unix seconds; expected GPS seconds of week (0..604800) as [time] base = "
        '"gps_tow" says: set [time] base = "unix" in session.toml'
    )
    assert _problems(sample_dir) == [
        f"nav_A.csv: times 1633651182.000..1633651186.900 {expected}",
        f"nav_B.csv: times 1633651182.000..1633651186.900 {expected}",
        f"nav_C.csv: times 1633651182.000..1633651186.900 {expected}",
        f"ranges.csv: times 1633651182.000..1633651186.000 {expected}",
    ]


def test_one_file_in_another_time_base_is_the_one_to_convert(sample_dir: Path) -> None:
    _times(sample_dir, lambda t: t - 432000.0 + 1633651182.0, "nav_B.csv")
    assert _problems(sample_dir) == [
        "nav_B.csv: times 1633651182.000..1633651186.900 look like Unix seconds; expected "
        'GPS seconds of week (0..604800) as [time] base = "gps_tow" says: convert them to '
        "GPS seconds of week like nav_A.csv"
    ]


def test_millimetre_ranges(sample_dir: Path) -> None:
    path = sample_dir / "ranges.csv"
    frame = pd.read_csv(path)
    frame["range"] = frame["range"] * 1000.0 + 7345.0
    frame.to_csv(path, index=False)
    assert _problems(sample_dir) == [
        "ranges.csv:2: ranges look like millimetres (median 14,345; 20 of 20 rows above "
        "2000); expected metres: divide the ranges by 1000, or declare session.toml "
        '[columns.units] range = "mm"'
    ]
    frame["sigma"] = 100.0
    frame.to_csv(path, index=False)
    assert "divide the ranges and sigmas by 1000, or declare" in _problems(sample_dir)[0]


def test_a_few_absurd_ranges_are_outliers_not_millimetres(sample_dir: Path) -> None:
    path = sample_dir / "ranges.csv"
    lines = path.read_text().splitlines()
    lines[5] = "432001.000000,B,A,12000.0,0.1,-78.0"
    path.write_text("\n".join(lines) + "\n")
    assert _problems(sample_dir) == [
        "ranges.csv:6: range 12000.0 m is absurd for UWB; expected 0..2000 m"
    ]


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        (
            "ranges.csv",
            "ranges.csv:1: first line is not a header (found values like 432000.000000, A, "
            "B, ...); expected the header time,from,to,range (then optional sigma and extra "
            "columns)",
        ),
        (
            "nav_A.csv",
            "nav_A.csv:1: first line is not a header (found values like 432000.000000, "
            "0.000062, 0.014937, ...); expected the header time,east,north,up (or "
            "lat,lon,height or x,y,z for the position)",
        ),
    ],
)
def test_headerless_csv_is_one_line(sample_dir: Path, name: str, expected: str) -> None:
    path = sample_dir / name
    path.write_text("".join(path.read_text().splitlines(keepends=True)[1:]))
    assert _problems(sample_dir) == [expected]


def test_headerless_csv_after_comments(sample_dir: Path) -> None:
    path = sample_dir / "ranges.csv"
    rows = path.read_text().splitlines(keepends=True)[1:]
    path.write_text("# exported by the logger\n" + "".join(rows))
    assert _problems(sample_dir) == [
        "ranges.csv:2: first line after the comments is not a header (found values like "
        "432000.000000, A, B, ...); expected the header time,from,to,range (then optional "
        "sigma and extra columns)"
    ]


@pytest.mark.parametrize(
    ("name", "sep", "said"), [("ranges.csv", ";", "';'-delimited"), ("nav_B.csv", "\t", "tab")]
)
def test_other_separator_is_read_with_a_note(
    sample_dir: Path, name: str, sep: str, said: str
) -> None:
    """Issue 14: ';' and tab files are read (they were one error), and a note says so."""
    from coopproc.io import read_session

    plain = read_session(sample_dir)
    path = sample_dir / name
    path.write_text(path.read_text().replace(",", sep))
    other = read_session(sample_dir)
    assert f"{path}: read as {said}" in " ".join(other.notes)
    assert other.ranges.frame.equals(plain.ranges.frame)


@pytest.mark.parametrize(
    ("times", "kind"),
    [
        (1633651200.0 + np.arange(10) * 0.1, "unix"),
        (1633651200e3 + np.arange(10) * 100.0, "unix_ms"),
        (432000.0 + np.arange(10) * 0.1, "tow"),
        (432000e3 + np.arange(10) * 100.0, "ms"),
        (np.arange(10) * 100.0, "ms"),
        (np.arange(10) * 1.0, "tow"),
        (-5.0 + np.arange(10) * 1.0, "relative"),
        (432000e3 + np.arange(3) * 100.0, "unix"),  # too few epochs to judge the spacing
        (np.array([-1e12, 0.0]), "other"),
    ],
)
def test_looks_like(times: np.ndarray, kind: str) -> None:
    assert looks_like(times)[0] == kind
