"""The package imports, has a version, and every CLI command has help."""

from click.testing import CliRunner

import coopproc
from coopproc.cli import main


def test_version_is_set() -> None:
    assert coopproc.__version__.count(".") >= 2


def test_every_command_has_help() -> None:
    runner = CliRunner()
    result = runner.invoke(main, ["--help"])
    assert result.exit_code == 0
    for name in main.commands:
        sub = runner.invoke(main, [name, "--help"])
        assert sub.exit_code == 0, name
        assert "Usage:" in sub.output
