"""The shortcuts that make reading a day of logs fast give what the plain ways give.

Each test compares a fast path with the computation it replaces (which is kept as the
reference here), on inputs chosen so that a wrong shortcut would differ.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.checks.coverage import restrict_to_coverage
from coopproc.errors import InputError
from coopproc.io import csv_head, read_session, validate_session
from coopproc.io._common import Locator
from coopproc.io.ranges_csv import _duplicated, range_table_from_frame, read_ranges_csv
from coopproc.io.timebase import _median_step
from coopproc.model import RangeTable, Trajectory

REPO = Path(__file__).resolve().parents[2]


def _traj(time_s: list[float], nan_row: int | None = None) -> Trajectory:
    t = np.asarray(time_s, dtype=np.float64)
    enu = np.column_stack([t, 2 * t, np.zeros_like(t)])
    if nan_row is not None:
        enu[nan_row, 0] = np.nan
    return Trajectory("A", t, enu)


@pytest.mark.parametrize("nan_row", [None, 2])
def test_covered_is_where_interpolate_within_gives_a_position(nan_row: int | None) -> None:
    traj = _traj([0.0, 1.0, 2.0, 3.0, 10.0, 11.0, 12.0, 13.0], nan_row)
    t = np.array([-1.0, 0.0, 0.5, 2.5, 3.0, 5.0, 9.99, 10.0, 12.5, 13.0, 13.01, np.nan])
    expected = ~np.isnan(traj.interpolate_within(t)[:, 0])
    np.testing.assert_array_equal(traj.covered(t), expected)
    assert not traj.covered(np.array([5.0]))[0]  # inside the gap 3-10
    assert traj.covered(np.array([10.0]))[0]  # exactly on the epoch after it


def _ranges_frame(categorical: bool) -> pd.DataFrame:
    frame = pd.DataFrame(
        {
            "time": [3.0, 1.0, 2.0, 2.0, 2.0, 4.0, 5.0],
            "from": ["C ", "B", " A", "A", " A", "B", "C"],
            "to": ["A", "C", "B", "B", "B", "A", "B "],
            "range": [1.0, 2.0, 3.0, 3.0, 3.0, 4.0, 5.0],
        }
    )
    for name in ("from", "to"):
        frame[name] = frame[name].astype("category" if categorical else "str")
    return frame


def test_categorical_ids_give_what_text_ids_give() -> None:
    where = Locator("ranges.csv")
    fast = range_table_from_frame(_ranges_frame(True), where)
    plain = range_table_from_frame(_ranges_frame(False), where)
    pd.testing.assert_frame_equal(fast.table.frame, plain.table.frame, check_exact=True)
    assert fast.notes == plain.notes
    np.testing.assert_array_equal(fast.order, plain.order)
    assert list(fast.table.frame["pair"]) == ["B-C", "A-B", "A-C", "A-B", "B-C"]
    # the reader's id codes are the ones the table computes from its frame
    fresh = RangeTable(fast.table.frame).id_codes
    for mine, theirs in zip(fast.table.id_codes, fresh, strict=True):
        np.testing.assert_array_equal(mine, theirs)


@pytest.mark.parametrize("bad", ["", "A B", "Cé"])
def test_categorical_ids_give_the_same_errors(bad: str) -> None:
    messages = []
    for categorical in (True, False):
        frame = _ranges_frame(categorical).astype({"from": object})
        frame.loc[4, "from"] = bad if bad else None
        frame["from"] = frame["from"].astype("category" if categorical else "str")
        with pytest.raises(InputError) as err:
            range_table_from_frame(frame, Locator("ranges.csv"))
        messages.append(str(err.value))
    assert messages[0] == messages[1]
    assert "column 'from'" in messages[0]


def test_duplicates_found_among_rows_of_equal_time() -> None:
    rng = np.random.default_rng(3)
    frame = pd.DataFrame(
        {
            "time": np.sort(rng.integers(0, 40, 300)).astype(np.float64),
            "pair": rng.choice(["A-B", "A-C"], 300),
            "range": rng.integers(0, 3, 300).astype(np.float64),
        }
    )
    dup = _duplicated(frame)
    np.testing.assert_array_equal(dup, frame.duplicated(keep="first").to_numpy())
    assert dup.any() and not dup.all()


def test_median_step_without_sorting() -> None:
    for t in (np.array([0.0, 0.1, 0.1, 0.3, 0.4, 0.4, 0.9]), np.array([0.4, 0.0, 0.1, 0.9, 0.3])):
        u = np.unique(t)
        assert _median_step(t) == float(np.median(np.diff(u)))


def test_restricted_table_keeps_matching_id_codes(tmp_path: Path) -> None:
    session = tmp_path / "s"
    shutil.copytree(REPO / "sample_logs", session, ignore=shutil.ignore_patterns("mcap", "truth"))
    nav = (session / "nav_C.csv").read_text().splitlines()
    (session / "nav_C.csv").write_text("\n".join(nav[:40]) + "\n")  # C's navigation ends early
    restricted, notes = restrict_to_coverage(read_session(session))
    assert notes and len(restricted.ranges) > 0
    fresh = RangeTable(restricted.ranges.frame).id_codes
    for mine, theirs in zip(restricted.ranges.id_codes, fresh, strict=True):
        np.testing.assert_array_equal(mine, theirs)


def test_non_ascii_byte_past_the_first_chunk_is_reported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(csv_head, "_CHUNK", 1 << 15)
    rows = [f"{100 + i * 0.1:.6f},A,B,{10 + i % 7}.5" for i in range(6000)]
    rows[5000] = rows[5000].replace(",A,", ",\xe9,")
    path = tmp_path / "ranges.csv"
    path.write_bytes(("time,from,to,range\n" + "\n".join(rows) + "\n").encode("latin-1"))
    assert path.stat().st_size > 2 * csv_head._CHUNK
    with pytest.raises(InputError) as err:
        read_ranges_csv(path)
    assert err.value.line == 5002
    assert "byte 0xe9" in str(err.value)
    path.write_bytes(path.read_bytes().replace(b"\xe9", b"C"))
    assert len(read_ranges_csv(path).table) == 6000


def test_problems_of_several_files_listed_in_file_order(tmp_path: Path) -> None:
    session = tmp_path / "s"
    shutil.copytree(REPO / "sample_logs", session, ignore=shutil.ignore_patterns("mcap", "truth"))
    (session / "nav_A.csv").write_text("time,east\n1,2\n")
    (session / "ref_C.pos").write_text("% no header\n")
    ranges = (session / "ranges.csv").read_text().replace(",A,B,", ",A B,B,", 1)
    (session / "ranges.csv").write_text(ranges)
    problems = validate_session(session)
    files = [p.split(":")[0].rsplit("/", 1)[-1] for p in problems]
    assert files == ["nav_A.csv", "ref_C.pos", "ranges.csv"]


@pytest.mark.parametrize("dtype", ["str", "object", "category"])
def test_id_codes_sort_the_ids_as_text(dtype: str) -> None:
    frame = pd.DataFrame({"from": ["C", "A", "B10", "C"], "to": ["A", "B2", "A", "B10"]})
    if dtype == "category":  # categories in another order than the text's
        for name in ("from", "to"):
            frame[name] = pd.Categorical(frame[name], categories=["C", "B2", "B10", "A"])
    else:
        frame = frame.astype(dtype)
    ids, first, second = RangeTable(frame).id_codes
    assert list(ids) == ["A", "B10", "B2", "C"]
    assert list(ids[first]) == ["C", "A", "B10", "C"]
    assert list(ids[second]) == ["A", "B2", "A", "B10"]
