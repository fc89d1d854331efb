"""Hostile numbers in every numeric column of every reader (issue 32, deliverable 1):
validate ends in success or one line per problem, never an internal error.

One small session (three platforms at 10 Hz for 5 s, 1 Hz ranges, .pos references, a
TUM navigation file, a 100 Hz IMU and a 10 Hz odometer); each example writes one value
(1e300, -1e300, 1e309 that overflows to inf, -0.0, a subnormal, NaN, inf, text, an
empty cell, or any float) into one cell of one file and validates the session.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from coopproc.cli import main
from coopproc.errors import CoopprocError
from coopproc.io import inspect_session, write_session, write_tum

#: More for a longer hunt: COOPPROC_FUZZ_EXAMPLES=500 pytest tests/io/test_numeric_fuzz.py
_SETTINGS = settings(
    max_examples=int(os.environ.get("COOPPROC_FUZZ_EXAMPLES", "12")),
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
HOSTILE = st.one_of(
    st.sampled_from(
        ["1e300", "-1e300", "1e309", "-0.0", "5e-324", "2.2e-308", "nan", "inf", "-inf", "x", ""]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)
#: file -> its numeric columns (the first line is the header; .pos and .tum by position)
FILES = {
    "nav_A.csv": ("time", "east", "north", "up", "sigma_east", "heading"),
    "nav_B.csv": ("time", "east", "north", "up"),
    "ranges.csv": ("time", "range", "sigma"),
    "imu_A.csv": ("time", "gyro_x", "accel_z"),
    "odo_B.csv": ("time", "speed"),
    "ref_A.pos": (2, 3, 4, 5),  # lat, lon, height, Q (whitespace fields)
    "nav_C.tum": (0, 1, 2, 3),  # time, x, y, z
}


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory, kit: type) -> Path:
    root = tmp_path_factory.mktemp("numfuzz") / "s"
    session = kit.make_session(n_nav=50)  # type: ignore[attr-defined]
    write_session(session, root)
    write_tum(session.nav["C"], root / "nav_C.tum")
    (root / "nav_C.csv").unlink()
    t = kit.T0 + np.arange(500) / 100.0  # type: ignore[attr-defined]
    imu = pd.DataFrame({"time": t})
    rng = np.random.default_rng(1)
    for i, axis in enumerate("xyz"):
        imu[f"gyro_{axis}"] = rng.normal(0.0, 1e-3, t.size)
        imu[f"accel_{axis}"] = rng.normal(0.0, 0.01, t.size) + (9.80665 if i == 2 else 0.0)
    imu.to_csv(root / "imu_A.csv", index=False)
    pd.DataFrame({"time": t[::10], "speed": 0.5}).to_csv(root / "odo_B.csv", index=False)
    return root


@pytest.fixture(scope="module")
def kit() -> type:
    from importlib import import_module

    return import_module("tests.io.conftest").Kit  # type: ignore[no-any-return]


def _put(path: Path, row: int, column: str | int, value: str) -> None:
    lines = path.read_text().splitlines(keepends=True)
    data = [i for i, x in enumerate(lines) if x.strip() and not x.startswith(("#", "%"))]
    if path.suffix == ".csv":
        header, data = data[0], data[1:]
        k = lines[header].strip().split(",").index(str(column))
        sep = ","
    else:
        k = int(column)
        sep = " "
    at = data[row % len(data)]
    parts = lines[at].rstrip("\n").split(sep if sep == "," else None)
    parts[k] = value
    lines[at] = sep.join(parts) + "\n"
    path.write_text("".join(lines))


@_SETTINGS
@given(
    name=st.sampled_from(sorted(FILES)),
    which=st.integers(0, 10),
    row=st.integers(0, 60),
    value=HOSTILE,
)
def test_hostile_numbers_end_in_success_or_one_line_each(
    template: Path, name: str, which: int, row: int, value: str
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "s"
        shutil.copytree(template, root)
        columns = FILES[name]
        _put(root / name, row, columns[which % len(columns)], value)
        try:
            _data, problems = inspect_session(root)
        except CoopprocError as err:  # pragma: no cover - inspect lists, never raises
            pytest.fail(f"raised {err}")
        assert all("\n" not in p and "internal error" not in p for p in problems)


def test_validate_cli_on_an_overflow_in_every_reader(template: Path, tmp_path: Path) -> None:
    """One example per reader through the command itself: exit 0 or 1, no internal error."""
    for name, columns in FILES.items():
        root = tmp_path / name.replace(".", "_")
        shutil.copytree(template, root)
        _put(root / name, 3, columns[1], "1e300")
        res = CliRunner().invoke(main, ["validate", str(root)])
        assert res.exit_code in (0, 1), (name, res.output)
        assert "internal error" not in res.output and "Traceback" not in res.output, name
