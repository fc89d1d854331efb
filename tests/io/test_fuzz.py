"""Random bytes and randomly corrupted files into every reader: read, or raise a coopproc
input/config error, never any other exception."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from coopproc.errors import CoopprocError
from coopproc.io import (
    read_pos,
    read_ranges_csv,
    read_session,
    read_session_toml,
    read_traj_csv,
    read_tum,
    write_mcap,
    write_session,
    write_tum,
)

#: More examples for a longer hunt: COOPPROC_FUZZ_EXAMPLES=2000 pytest tests/io/test_fuzz.py
_FUZZ = settings(
    max_examples=int(os.environ.get("COOPPROC_FUZZ_EXAMPLES", "40")),
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

Reader = Callable[[Path], Any]

READERS: dict[str, tuple[str, Reader]] = {
    "nav_csv": ("nav_A.csv", lambda p: read_traj_csv(p, "A")),
    "nav_csv_gz": ("nav_A.csv.gz", lambda p: read_traj_csv(p, "A")),
    "tum": ("nav_A.tum", lambda p: read_tum(p, "A")),
    "pos": ("ref_A.pos", lambda p: read_pos(p, "A")),
    "ranges": ("ranges.csv", read_ranges_csv),
    "toml": ("session.toml", read_session_toml),
    "mcap": ("s.mcap", read_session),
    "mcap_ros2": ("r.mcap", read_session),
    "mcap_plain": ("p.mcap", read_session),
    "mcap_ros2_plain": ("q.mcap", read_session),
}


def _samples(kit: Any) -> dict[str, bytes]:
    """Valid bytes of each format, from a small session written with the writers."""
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        s = kit.make_session(n_nav=12)
        write_session(s, d)
        write_session(s, d / "gz", compress=True)
        write_tum(s.nav["A"], d / "nav_A.tum")
        write_mcap(s, d / "s.mcap")
        write_mcap(s, d / "r.mcap", encoding="ros2")
        write_mcap(s, d / "p.mcap", compression="none")
        write_mcap(s, d / "q.mcap", encoding="ros2", compression="none")
        files = {k: (d / name) for k, (name, _) in READERS.items()}
        files["nav_csv_gz"] = d / "gz" / "nav_A.csv.gz"
        return {k: p.read_bytes() for k, p in files.items()}


def _check(kind: str, data: bytes) -> None:
    name, reader = READERS[kind]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        path.write_bytes(data)
        try:
            reader(path)
        except CoopprocError as err:
            assert str(err) and "\n" not in str(err).strip()


@pytest.mark.parametrize("kind", sorted(READERS))
@_FUZZ
@given(data=st.binary(max_size=400))
def test_random_bytes(kind: str, data: bytes) -> None:
    _check(kind, data)


_OPS = st.lists(
    st.tuples(
        st.floats(0, 1, exclude_max=True),
        st.sampled_from(["delete", "insert", "replace", "truncate", "duplicate"]),
        st.sampled_from(list(",.-\n#%eE+0123456789 nan[]=\"'/x\x00\xff")),
    ),
    min_size=1,
    max_size=6,
)


def _corrupt(data: bytes, ops: list[tuple[float, str, str]]) -> bytes:
    out = bytearray(data)
    for where, op, char in ops:
        i = int(where * len(out)) if out else 0
        c = char.encode("latin-1")
        if op == "delete" and out:
            del out[i : i + 1 + i % 7]
        elif op == "insert":
            out[i:i] = c
        elif op == "replace" and out:
            out[i : i + 1] = c
        elif op == "truncate":
            del out[i:]
        elif op == "duplicate" and out:
            out[i:i] = out[i : i + 40]
    return bytes(out)


@pytest.mark.parametrize("kind", sorted(READERS))
@_FUZZ
@given(ops=_OPS)
def test_corrupted_files(kit: Any, kind: str, ops: list[tuple[float, str, str]]) -> None:
    samples = _samples_cached(kit)
    data = samples[kind]
    if kind in ("nav_csv_gz", "mcap", "mcap_ros2", "mcap_plain", "mcap_ros2_plain"):
        # Compressed containers: corrupt the bytes; also corrupt the text inside for gz.
        _check(kind, _corrupt(data, ops))
        if kind == "nav_csv_gz":
            import gzip

            _check(kind, gzip.compress(_corrupt(gzip.decompress(data), ops), mtime=0))
        return
    _check(kind, _corrupt(data, ops))


_CACHE: dict[str, bytes] = {}


def _samples_cached(kit: Any) -> dict[str, bytes]:
    if not _CACHE:
        _CACHE.update(_samples(kit))
    return _CACHE


@_FUZZ
@given(ops=_OPS, target=st.sampled_from(["nav_B.csv", "ranges.csv", "ref_C.pos", "session.toml"]))
def test_corrupted_session_directory(
    kit: Any, ops: list[tuple[float, str, str]], target: str
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_session(kit.make_session(n_nav=12), d)
        path = d / target
        path.write_bytes(_corrupt(path.read_bytes(), ops))
        with contextlib.suppress(CoopprocError):
            read_session(d)
