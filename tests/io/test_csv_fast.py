"""The compiled CSV writer (coopproc.io.csv_fast) against pandas' own bytes."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coopproc.io.csv_fast import FAST_LIMIT, csv_bytes, csv_chunks, round_like_csv
from coopproc.io.csv_gzip import write_csv_gzip
from coopproc.io.outdir import FLOAT_FORMAT, csv_text, write_csv


def _pandas(frame: pd.DataFrame) -> bytes:
    text = frame.to_csv(index=False, float_format=FLOAT_FORMAT, lineterminator="\n")
    return str(text).encode("utf-8")


def _same(frame: pd.DataFrame) -> None:
    ours = csv_bytes(frame)
    assert ours is not None, "the fast writer refused a table it should take"
    theirs = _pandas(frame)
    if ours != theirs:  # the first differing line, readable
        for a, b in zip(ours.split(b"\n"), theirs.split(b"\n"), strict=False):
            assert a == b
    assert ours == theirs


#: Values where "%.6f" rounding is delicate: halfway in decimal but not in binary, exact
#: binary ties (k / 128: 0.0078125 -> 0.007812, ties to even), negative values that round
#: to -0.000000, -0.0, the limit of the compiled path and beyond it.
EDGES = [
    0.0,
    -0.0,
    5e-7,
    -5e-7,
    2.5e-7,
    1.5e-6,
    2.5e-6,
    -1e-9,
    -4.9e-7,
    0.0078125,
    0.0234375,
    -0.0078125,
    1 / 64,
    0.5,
    1.0000005,
    123.4567895,
    1e15,
    -1e15,
    FAST_LIMIT,
    -FAST_LIMIT,
    np.nextafter(FAST_LIMIT, 0.0),
    1e300,
    -1.7976931348623157e308,
    5e-324,
    -5e-324,
    1.7e9 + 0.0078125,
    np.nan,
    np.inf,
    -np.inf,
]


def test_float_edges_match_pandas() -> None:
    values = np.array(EDGES)
    _same(pd.DataFrame({"x": values, "y": values[::-1]}))


def test_exact_binary_ties_round_to_even() -> None:
    # (2k + 1) / 2**7 / 1e6 ... every multiple of 2**-7 with odd numerator is a tie of "%.6f"
    k = np.arange(-5000, 5000)
    ties = (2 * k + 1) / 128.0
    frame = pd.DataFrame({"t": ties, "u": ties + 1.7e9, "v": ties * 1024})
    _same(frame)
    assert csv_text(frame).splitlines()[1 + 5000].startswith("0.007812,")


@pytest.mark.parametrize("seed", range(6))
def test_random_floats_of_every_scale_match_pandas(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 20000
    mantissa = rng.uniform(-1, 1, n)
    scale = 10.0 ** rng.integers(-12, 18, n)
    x = mantissa * scale
    x[rng.random(n) < 0.05] = np.nan
    # random bit patterns: every exponent, subnormals, both zeros
    bits = rng.integers(0, 2**63, n, dtype=np.int64).view(np.float64)
    bits = np.where(rng.random(n) < 0.5, -bits, bits)
    # decimal "halves" at the 7th digit: k * 1e-6 + 5e-7 in every magnitude
    halves = (rng.integers(-(10**12), 10**12, n) + 0.5) / 1e6
    _same(pd.DataFrame({"x": x, "bits": bits, "halves": halves, "x32": x.astype(np.float32)}))


@given(
    st.lists(
        st.tuples(
            st.floats(allow_nan=True, allow_infinity=True),
            st.floats(min_value=-1e10, max_value=1e10),
            st.integers(min_value=-(2**63) + 1, max_value=2**63 - 1),
            st.one_of(st.none(), st.text(max_size=6)),
            st.booleans(),
        ),
        min_size=0,
        max_size=30,
    )
)
@settings(max_examples=300, deadline=None)
def test_hypothesis_tables_match_pandas(rows: list[tuple[float, float, int, str, bool]]) -> None:
    frame = pd.DataFrame(rows, columns=["a", "b", "i", "s", "flag"])
    frame = frame.astype({"a": np.float64, "b": np.float64, "i": np.int64, "flag": bool})
    if "\0" in "".join(s for s in frame["s"] if isinstance(s, str)):
        assert csv_bytes(frame) is None
        return
    _same(frame)


def test_text_needing_quotes_and_missing_values() -> None:
    texts = ["plain", "a,b", 'say "hi"', "two\nlines", "cr\rhere", "", None, " pad ", "é€"]
    frame = pd.DataFrame({"s": texts, "o": pd.Series(texts, dtype=object), "n": range(9)})
    _same(frame)
    _same(frame.astype({"s": "str"}))


def test_categorical_text_is_taken_in_chunks_with_the_bytes_of_pandas() -> None:
    texts = ["plain", "a,b", 'say "hi"', "unused"]
    codes = np.array([0, 1, 2, -1, 1, 0, 2, 2, -1, 0], dtype=np.int8)
    frame = pd.DataFrame(
        {
            "o": pd.Series(["x", "y,z"] * 5),  # a text column before: codes are offset
            "c": pd.Categorical.from_codes(codes, categories=texts),
            "x": np.linspace(0.0, 1.0, 10),
        }
    )
    pieces = csv_chunks(frame, chunk_rows=3)
    assert pieces is not None  # not handed to pandas
    assert b"".join(bytes(p) for p in pieces) == _pandas(frame)


def test_integer_columns_match_pandas() -> None:
    ints = np.array([0, 1, -1, 9, -10, 99, 100, -(2**63) + 1, 2**63 - 1], dtype=np.int64)
    frame = pd.DataFrame(
        {
            "i64": ints,
            "i32": ints.astype(np.int32),
            "u8": np.arange(9, dtype=np.uint8),
            "u64": np.arange(9, dtype=np.uint64) * 10**18,
            "b": [True, False, True, True, False, False, True, False, True],
        }
    )
    _same(frame)


def test_header_and_empty_tables_match_pandas() -> None:
    _same(pd.DataFrame({"time": np.array([], dtype=float), "pair": pd.Series([], dtype=str)}))
    _same(pd.DataFrame({"a,b": [1.0], 'q"': ["x"]}))


@pytest.mark.parametrize(
    "frame",
    [
        pd.DataFrame({"one": [1.0, np.nan]}),  # a lone empty cell is written as ""
        pd.DataFrame({"a": [1.0], "d": pd.to_datetime(["2024-01-01"])}),
        pd.DataFrame({"a": [1.0], "m": [object()]}),
        pd.DataFrame({"a": [1.0], "x": pd.array([1], dtype="Int64")}),
        pd.DataFrame({0: [1.0], 1: [2.0]}),
        pd.DataFrame({"a": [1.0], "s": ["nul\0"]}),
        pd.DataFrame({"a": [1, 2], "i": np.array([-(2**63), 0], dtype=np.int64)}),
    ],
)
def test_tables_it_does_not_take_are_written_by_pandas(frame: pd.DataFrame, tmp_path: Path) -> None:
    assert csv_chunks(frame) is None
    path = write_csv(frame, tmp_path / "t.csv")
    assert path.read_bytes() == _pandas(frame)


def test_chunks_join_to_the_same_bytes() -> None:
    rng = np.random.default_rng(7)
    frame = pd.DataFrame({"x": rng.normal(size=1001), "p": rng.choice(["A", "B,C"], 1001)})
    pieces = csv_chunks(frame, chunk_rows=100)
    assert pieces is not None
    assert b"".join(bytes(p) for p in pieces) == _pandas(frame)


def _positions_like(n: int, seed: int = 3) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    frame = pd.DataFrame(
        {
            "time": 1.7e9 + np.arange(n) * 0.01,
            "platform": rng.choice(["A", "B", "C"], n),
            "method": rng.choice(["observed", "di", "nav"], n),
        }
    )
    for name in ("east", "north", "up", "error_h"):
        values = rng.normal(0, 300, n)
        values[rng.random(n) < 0.1] = np.nan
        frame[name] = values
    frame["n"] = rng.integers(-5, 5, n)
    return frame


# the 150 000-row gzip case is slow (pandas writes and gzips them); gzip over chunks is also
# checked at 7 and 1000 rows a chunk below
@pytest.mark.parametrize(
    "name", ["positions.csv", pytest.param("positions.csv.gz", marks=pytest.mark.slow)]
)
def test_write_csv_gives_the_bytes_of_pandas(name: str, tmp_path: Path) -> None:
    frame = _positions_like(150_000)  # more than one chunk
    ours = write_csv(frame, tmp_path / name)
    theirs = tmp_path / "pandas" / name
    theirs.parent.mkdir()
    frame.to_csv(
        theirs,
        index=False,
        float_format=FLOAT_FORMAT,
        lineterminator="\n",
        compression={"method": "gzip", "mtime": 0} if name.endswith(".gz") else None,
    )
    assert ours.read_bytes() == theirs.read_bytes()
    if name.endswith(".gz"):
        assert gzip.decompress(ours.read_bytes()) == _pandas(frame)


def test_write_csv_orders_the_columns(tmp_path: Path) -> None:
    frame = _positions_like(10)
    path = write_csv(frame, tmp_path / "p.csv", columns=["method", "time"])
    assert path.read_text().splitlines()[0] == "method,time,platform,east,north,up,error_h,n"


@pytest.mark.parametrize("chunk_rows", [7, 1000])
def test_gzip_bytes_with_rows_longer_than_the_text_buffer(chunk_rows: int, tmp_path: Path) -> None:
    # rows of 1 byte to 3x the 8192-byte text buffer of pandas' writer, cut into chunks
    rng = np.random.default_rng(11)
    n = 400
    lengths = np.where(rng.random(n) < 0.1, rng.integers(8000, 25000, n), rng.integers(0, 60, n))
    texts = ["".join(rng.choice(list('ab,"\n x'), k)) for k in lengths]
    frame = pd.DataFrame({"x": rng.normal(size=n), "text": texts})
    ours = tmp_path / "t.csv.gz"
    assert write_csv_gzip(frame, ours, chunk_rows=chunk_rows)
    theirs = tmp_path / "pandas.csv.gz"
    frame.to_csv(
        theirs,
        index=False,
        float_format=FLOAT_FORMAT,
        lineterminator="\n",
        compression={"method": "gzip", "mtime": 0},
    )
    # the gzip header names the file: compare with the pandas file's name in it
    assert gzip.decompress(ours.read_bytes()) == _pandas(frame)
    assert ours.read_bytes().replace(b"t.csv\0", b"pandas.csv\0", 1) == theirs.read_bytes()


def test_round_like_csv_gives_the_numbers_read_back_from_the_text() -> None:
    rng = np.random.default_rng(5)
    x = np.concatenate(
        [
            np.array(EDGES),
            rng.uniform(-1, 1, 5000) * 10.0 ** rng.integers(-9, 12, 5000),
            rng.integers(0, 2**63, 2000, dtype=np.int64).view(np.float64),
        ]
    )
    text = csv_text(pd.DataFrame({"x": x, "y": x}))
    back = [float(line.split(",")[0]) if line[0] != "," else np.nan for line in text.split()[1:]]
    got = round_like_csv(x)
    np.testing.assert_array_equal(got, np.array(back))
    assert np.array_equal(np.signbit(got), np.signbit(np.array(back)))


def test_many_chunks_formatted_ahead_come_in_order_with_the_bytes_of_pandas() -> None:
    # AHEAD chunks are formatted in threads while the caller holds one: 143 chunks through
    # AHEAD + 1 buffers, each piece copied before the next is asked for
    rng = np.random.default_rng(5)
    frame = pd.DataFrame(
        {
            "time": 1.7e9 + np.arange(1000) * 0.013,
            "name": pd.Categorical.from_codes(rng.integers(0, 3, 1000), ["a", "b,c", "d"]),
            "x": rng.normal(0.0, 50.0, 1000),
            "n": rng.integers(-5, 5, 1000),
        }
    )
    pieces = csv_chunks(frame, chunk_rows=7)
    assert pieces is not None
    assert b"".join(bytes(p) for p in pieces) == _pandas(frame)
