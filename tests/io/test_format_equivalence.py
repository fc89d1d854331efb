"""One session as CSV/.pos files, as JSON MCAP and as ROS 2 MCAP gives the same tables.

``coopproc simulate --mcap`` writes the session files and the same session as one MCAP
file; ``coopproc run --no-figures`` on each form must write every CSV table byte for byte
the same. The session has float (Q 2) reference epochs, which NavSatFix must keep apart
from fixed ones (they used to become reference), and values the JSON writer must write
to the last bit (it used to stop at 15 digits).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io.mcap_write import json_lines

SCENARIO = "paper-experiment"


def _cli(*args: str) -> None:
    res = CliRunner().invoke(main, list(args))
    assert res.exit_code == 0, res.output


@pytest.mark.slow
def test_csv_json_mcap_and_ros2_mcap_give_byte_identical_tables(tmp_path: Path) -> None:
    forms: dict[str, Path] = {}
    for encoding in ("json", "ros2"):
        out = tmp_path / f"sim_{encoding}"
        _cli(
            "simulate", str(out), "--scenario", SCENARIO, "--duration", "90",
            "--set", "float_fraction=0.3", "--mcap", "--mcap-encoding", encoding,
        )  # fmt: skip
        forms[encoding] = out / "mcap" / f"{SCENARIO}.mcap"
    forms["csv"] = tmp_path / "sim_json"
    pos = (forms["csv"] / "ref_A.pos").read_text().splitlines()
    q = [line.split()[5] for line in pos if not line.startswith("%")]
    assert q.count("2") > 0 and q.count("1") > 0  # float epochs to keep apart
    tables: dict[str, dict[str, bytes]] = {}
    for name, session in forms.items():
        out = tmp_path / f"out_{name}"
        _cli("run", str(session), "-o", str(out), "--no-figures", "-q")
        tables[name] = {p.name: p.read_bytes() for p in sorted(out.glob("*.csv"))}
    assert {"positions.csv", "metrics.csv", "nlos_events.csv"} <= set(tables["csv"])
    for name in ("json", "ros2"):
        assert sorted(tables[name]) == sorted(tables["csv"])
        differ = [f for f in tables["csv"] if tables[name][f] != tables["csv"][f]]
        assert not differ, f"{name} MCAP gives other tables than the CSV files: {differ}"


def test_json_lines_write_every_double_exactly() -> None:
    values = [0.1 + 0.2, 1 / 3, 432000.0 + 1 / 7, -2.5e-300, 1e22, 12.0]
    frame = pd.DataFrame(
        {"time": values, "id": ["A", 'q"x', "B", "C", "D", "E"], "q": [1, 2, 3, 4, 5, 6]}
    )
    frame.loc[5, "time"] = np.nan
    rows = [json.loads(line) for line in json_lines(frame)]
    assert [r["time"] for r in rows[:5]] == values[:5]  # bit for bit, not to 15 digits
    assert rows[5]["time"] is None and [r["id"] for r in rows][1] == 'q"x'
    assert [r["q"] for r in rows] == [1, 2, 3, 4, 5, 6]
    assert list(rows[0]) == ["time", "id", "q"]
