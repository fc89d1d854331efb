"""run.json's input digests, computed in a thread while the run works (issue 11)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from coopproc.run.output import hash_inputs


def test_the_digests_are_the_files_sha256(tmp_path: Path) -> None:
    files = []
    for k, size in enumerate((0, 5, 3 << 20)):  # empty, small, over one 1 MB block
        path = tmp_path / f"f{k}.bin"
        path.write_bytes(bytes(range(256)) * (size // 256) + b"x" * (size % 256))
        files.append(path)
    digests = hash_inputs(files).result()
    assert digests == {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def test_a_file_gone_is_the_error_of_reading_it(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        hash_inputs([tmp_path / "missing.csv"]).result()
