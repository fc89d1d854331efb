"""Issue 14 item 2 (5, 6): other file and column names and units in session.toml
(``[files]``, ``[columns]``), and copies and backups left out of a session with a note."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io import read_session, validate_session
from coopproc.io.registry import find_files
from coopproc.model import SessionConfig

sys.path.insert(0, str(Path(__file__).parent))
from csv_export_kit import add_toml, assert_same, notes, rewrite

# -- 5. [files] and [columns]: other names and units ---------------------------------

_MAPPING = """
[files]
nav.A = "robotA_odom.csv"
ranges = "uwb_log.csv"
[columns]
time = "stamp"
heading = "yaw"
vel_east = "ve"
[columns.units]
time = "us"
position = "mm"
heading = "rad"
velocity = "km/h"
[columns.ranges]
time = "t_ns"
range = "dist_mm"
from = "src"
[columns.ranges.units]
time = "ns"
range = "mm"
"""


def test_mapped_names_and_units_give_the_plain_session(sample_dir: Path) -> None:
    plain = read_session(sample_dir)
    for pid in "ABC":  # [columns] serves every nav file alike
        nav = sample_dir / f"nav_{pid}.csv"
        frame = pd.read_csv(nav)
        frame["time"] = (frame["time"] * 1e6).round().astype(np.int64)
        for c in ("east", "north", "up", "sigma_east", "sigma_north", "sigma_up"):
            frame[c] *= 1000.0
        frame["vel_east"] *= 3.6
        frame["heading"] = np.radians(frame["heading"])
        target = sample_dir / ("robotA_odom.csv" if pid == "A" else nav.name)
        nav.unlink()
        frame.rename(columns={"time": "stamp", "heading": "yaw", "vel_east": "ve"}).to_csv(
            target, index=False, float_format="%.17g"
        )
    rewrite(
        sample_dir / "ranges.csv",
        header={"time": "t_ns", "range": "dist_mm", "from": "src"},
        scale={"time": 9, "range": 3, "sigma": 3},
        dst=sample_dir / "uwb_log.csv",
    )
    add_toml(sample_dir, _MAPPING)
    other = read_session(sample_dir)
    assert_same(plain, other, exact=False)
    # whole numbers of the file's unit convert exactly
    assert np.array_equal(other.nav["A"].time_s, plain.nav["A"].time_s)
    assert np.array_equal(other.ranges.frame["range"], plain.ranges.frame["range"])
    text = notes(other)
    assert (
        "uwb_log.csv: session.toml [columns]: 't_ns' as time, 'dist_mm' as range, 'src' as from"
        in text
    )
    assert "uwb_log.csv: units converted: range, sigma mm -> m; time ns -> s" in text
    assert (
        "robotA_odom.csv: units converted: heading rad -> deg; east, north, up, sigma_east" in text
    )


def test_a_mapping_may_swap_columns(sample_dir: Path) -> None:
    plain = read_session(sample_dir)
    add_toml(sample_dir, '[columns.nav]\neast = "north"\nnorth = "east"\n')
    swapped = read_session(sample_dir)
    for pid in plain.nav:
        assert np.array_equal(swapped.nav[pid].enu_m[:, [1, 0, 2]], plain.nav[pid].enu_m)
    assert np.array_equal(swapped.reference["A"].enu_m, plain.reference["A"].enu_m)  # .pos


@pytest.mark.parametrize(
    ("toml", "expected"),
    [
        ('[columns]\ntiem = "t"', "[columns]: unknown key 'tiem' (did you mean 'time'?)"),
        (
            '[columns.units]\ntime = "msec"',
            "[columns.units] time: 'msec' (did you mean 'ms'?); expected s | ms | us | ns",
        ),
        ('[columns.units]\nlength = "mm"', "[columns.units]: unknown key 'length'"),
        (
            '[columns.ranges]\neast = "x"',
            "[columns.ranges]: unknown key 'east' (valid keys: from, range, sigma, time, to, "
            "units)",
        ),
        ('[columns.nav.units]\nrange = "mm"', "[columns.nav.units]: unknown key 'range'"),
        (
            '[columns]\ntime = "t"\n[columns.ranges]\nrange = "t"',
            "[columns]: time and range both name column 't' of the ranges files; expected one "
            "column per name",
        ),
        ("[columns]\ntime = 3", "[columns] time: expected the column's name in the file, found 3"),
        (
            '[files]\nencodng = "cp1252"',
            "[files]: unknown key 'encodng' (did you mean 'encoding'?)",
        ),
        (
            '[files]\nencoding = "latin-9x"',
            "[files] encoding: 'latin-9x' is not a text encoding (did you mean 'latin-1'?)",
        ),
        (
            '[files.encodings]\nnav.A = "rot13"',
            "[files.encodings] nav.A: 'rot13' is not a text encoding",
        ),
    ],
)
def test_bad_mappings_are_one_line(sample_dir: Path, toml: str, expected: str) -> None:
    add_toml(sample_dir, toml)
    (msg,) = validate_session(sample_dir)
    assert msg.startswith(f"{sample_dir / 'session.toml'} {expected}")


def test_a_mapped_column_missing_from_the_file(sample_dir: Path) -> None:
    add_toml(sample_dir, '[columns.ranges]\nrange = "dist"\n')
    assert validate_session(sample_dir) == []  # the file's own 'range' column serves
    rewrite(sample_dir / "ranges.csv", header={"range": "distance"})
    (msg,) = validate_session(sample_dir)
    assert msg == (
        f"{sample_dir / 'ranges.csv'}: missing column 'dist' ([columns] range); found "
        "'distance' (misspelled?)"
    )


# -- 6. copies and backups -----------------------------------------------------------


def test_copies_and_backups_are_left_out_with_a_note(sample_dir: Path) -> None:
    plain = read_session(sample_dir)
    for copy in ("nav_A_backup.csv", "nav_A (copy).csv", "nav_A.csv.bak", "nav_B_2.csv"):
        shutil.copy(sample_dir / "nav_A.csv", sample_dir / copy)
    shutil.copy(sample_dir / "ref_B.pos", sample_dir / "ref_B_old.pos")
    shutil.copy(sample_dir / "ranges.csv", sample_dir / "ranges (1).csv")
    other = read_session(sample_dir)
    assert_same(plain, other)
    text = notes(other)
    for line in (
        "nav_A_backup.csv: ignored: platform 'A_backup' is not declared in session.toml "
        "[platforms] (a copy of A's file?); declare [platforms.A_backup] in session.toml to "
        "read it",
        "nav_B_2.csv: ignored: platform 'B_2' is not declared in session.toml [platforms] "
        "(a copy of B's file?)",
        "ref_B_old.pos: ignored: platform 'B_old' is not declared",
        "nav_A (copy).csv: ignored: not a session file name (a copy of nav_A.csv?)",
        "nav_A.csv.bak: ignored: not a session file name (a copy of nav_A.csv?)",
        "ranges (1).csv: ignored: not a session file name (a copy of ranges.csv?)",
    ):
        assert line in text
    res = CliRunner().invoke(main, ["validate", str(sample_dir)])
    assert res.exit_code == 0, res.output
    assert res.output.count("warning: ") == 6 and res.output.endswith(": ok (6 warnings)\n")
    # a declared id is read, whatever it looks like
    add_toml(sample_dir, '[platforms.A_backup]\nrole = "follower"\n')
    assert "A_backup" in read_session(sample_dir).nav


def test_without_declared_platforms_copy_words_decide(sample_dir: Path) -> None:
    for copy in ("nav_A_old.csv", "nav_C-copy2.csv", "nav_A2.csv"):
        shutil.copy(sample_dir / "nav_A.csv", sample_dir / copy)
    files = find_files(sample_dir, SessionConfig())
    assert sorted(files.nav) == ["A", "A2", "B", "C"]  # A2 is a platform id, not a copy
    assert [n.split(": ", 1)[1] for n in files.notes] == [
        "ignored: 'A_old' looks like a copy of A's file; declare [platforms.A_old] in "
        "session.toml to read it",
        "ignored: 'C-copy2' looks like a copy of C's file; declare [platforms.C-copy2] in "
        "session.toml to read it",
    ]
    add_toml(sample_dir, '[files]\nnav.A = "nav_A_old.csv"\n')  # named in [files]: read
    config = read_session(sample_dir).config
    assert find_files(sample_dir, config).nav["A"].name == "nav_A_old.csv"
