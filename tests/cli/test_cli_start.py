"""CLI start and output streams (issue 16, item 5).

``coopproc --version`` and the help pages import no numerical library (their speed is
measured by benchmarks/cli_start.py, not here); ``coopproc run`` prints its closing
summary on stdout and its progress and notes on stderr.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.cli.commands import COMMANDS, load_all

HEAVY = ("numpy", "pandas", "scipy", "matplotlib", "numba", "coopproc.io", "coopproc.sim")

_PROBE = """
import sys
from coopproc.cli import main
try:
    main(sys.argv[1:], prog_name="coopproc")
except SystemExit as exit:
    assert not exit.code, exit.code
heavy = sorted(m for m in {heavy!r} if m in sys.modules)
print("imported:", ",".join(heavy), file=sys.stderr)
"""


@pytest.mark.parametrize(
    "args",
    [
        ["--version"],
        ["--help"],
        ["run", "--help"],
        ["report", "--help"],
        ["locate", "--help"],
        ["validate", "--help"],
        ["info", "--help"],
        ["config", "--help"],
    ],
)
def test_version_and_help_import_no_numerical_library(args: list[str]) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", _PROBE.format(heavy=HEAVY), *args],
        capture_output=True,
        text=True,
        check=True,
    )
    assert proc.stderr.splitlines()[-1] == "imported: "
    assert proc.stdout  # the version or the help page was printed


def test_group_help_lists_every_command_with_its_own_summary() -> None:
    res = CliRunner().invoke(main, ["--help"])
    assert res.exit_code == 0
    commands = load_all()
    assert sorted(commands) == sorted(COMMANDS) == sorted(main.commands)
    for name, command in commands.items():
        for limit in (20, 45, 60, 200):
            lazy = click.Command(name, help=COMMANDS[name].summary).get_short_help_str(limit)
            assert lazy == command.get_short_help_str(limit), name
    # the section is what click writes for the imported commands
    eager = click.Group("coopproc", commands=commands)
    section = eager.get_help(click.Context(eager)).partition("Commands:")[2]
    assert section and res.output.endswith(section + "\n")


def test_unknown_command_is_a_usage_error() -> None:
    res = CliRunner().invoke(main, ["rnu"])
    assert res.exit_code == 2
    assert res.output.splitlines()[-1] == "Error: No such command 'rnu'. Did you mean 'run'?"


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("start") / "session"
    res = CliRunner().invoke(
        main, ["simulate", str(path), "--scenario", "paper-table1", "--duration", "60"]
    )
    assert res.exit_code == 0, res.output
    return path


def test_run_summary_on_stdout_notes_on_stderr(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(session), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    stdout = res.stdout.splitlines()
    assert stdout[0] == "self-calibration (declared values in brackets):"
    assert any(line.startswith("NLOS events (DI-Based): ") for line in stdout)
    # 14 CSV: comparisons.csv (report/comparisons.py) beside the 13 of before
    assert stdout[-2:] == [f"tables: {out}/ (14 CSV), figures: 0", f"report: {out}/report.html"]
    assert res.stderr.splitlines()[0].startswith("session ")
    assert "NLOS events" not in res.stderr and "tables:" not in res.stderr


def test_run_quiet_prints_nothing_on_either_stream(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "q"
    res = CliRunner().invoke(main, ["run", str(session), "-o", str(out), "-q", "--no-figures"])
    assert res.exit_code == 0, res.output
    assert res.stdout == "" and res.stderr == ""
