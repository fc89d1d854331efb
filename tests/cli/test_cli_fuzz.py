"""CLI fuzz: any command, options and paths end in success or one error line (issue 16, item 6).

Commands are drawn with their options, good and bad values, and paths of every kind
(a session, the shipped sample, missing, a file where a directory is expected, a path
under a file or a device, a directory that is not writable, a finished run, the session
itself as output). Whatever is drawn must end in exit status 0, or 1 with exactly one
``error:`` line (the last; ``validate`` lists its problems instead), or 2 with click's
usage error; never a traceback or an "internal error". ``batch`` (a Dask cluster per
call) is left to its own tests; ``locate`` gets a tiny particle count to stay fast.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from coopproc.cli import main

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"

#: Symbolic paths, made real for each example in a fresh directory (see _resolve).
INPUTS = ("<session>", "<sample>", "<mcap>", "<missing>", "<file>", "<empty>", "<run>")
OUTPUTS = (
    "<new>",
    "<nested>",
    "<empty>",
    "<nonempty>",
    "<file>",
    "<under-file>",
    "<under-device>",
    "<locked>/out",
    "<session-copy>",
    "<run-copy>",
)
CONFIGS = ("<good-config>", "<bad-toml>", "<unknown-key>", "<bad-value>", "<missing>", "<empty>")

_RUN_CONFIG = "[ranging.nlos]\ngamma_sigma = 3.0\n\n[locate]\nN = 8\nM = 8\n"
_CONFIG_TEXT = {
    "<good-config>": _RUN_CONFIG,
    "<bad-toml>": "[ranging\ngamma = \n",
    "<unknown-key>": "[ranging.nlos]\ngama_sigma = 2\n\n[locate]\nN = 8\nM = 8\nNN = 3\n",
    "<bad-value>": '[ranging.nlos]\ngamma_sigma = "three"\n\n[locate]\nN = -4\nM = 8\n',
}


@pytest.fixture(scope="module")
def arena(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small simulated session, a copy of the sample session and a finished run."""
    root = tmp_path_factory.mktemp("fuzz")
    runner = CliRunner()
    res = runner.invoke(
        main,
        ["simulate", str(root / "session"), "--scenario", "paper-table1", "--duration", "60"],
    )
    assert res.exit_code == 0, res.output
    shutil.copytree(SAMPLE, root / "sample")
    res = runner.invoke(
        main, ["run", str(root / "session"), "-o", str(root / "run"), "--no-figures", "-q"]
    )
    assert res.exit_code == 0, res.output
    return root


def _resolve(token: str, arena: Path, work: Path) -> str:
    """The real path of a symbolic one (fresh per example in ``work``)."""
    if not (token.startswith("<") and ">" in token):
        return token
    name, _, rest = token.partition(">")
    name += ">"
    fixed = {
        "<session>": arena / "session",
        "<sample>": arena / "sample",
        "<mcap>": arena / "sample" / "mcap" / "paper-experiment.mcap",
        "<run>": arena / "run",
        "<missing>": work / "missing",
        "<new>": work / "new",
        "<nested>": work / "a" / "b" / "out",
        "<under-file>": work / "afile" / "sub",
        "<under-device>": Path("/dev/null/out"),
    }
    if name in fixed:
        path = fixed[name]
        if name == "<under-file>":
            (work / "afile").write_text("a file\n")
    elif name == "<file>":
        path = work / "afile"
        path.write_text("a file\n")
    elif name == "<empty>":
        path = work / "empty"
        path.mkdir(exist_ok=True)
    elif name == "<nonempty>":
        path = work / "nonempty"
        path.mkdir(exist_ok=True)
        (path / "keep.txt").write_text("mine\n")
    elif name == "<locked>":
        path = work / "locked"
        path.mkdir(exist_ok=True)
        path.chmod(0o555)
    elif name == "<session-copy>":
        path = work / "session"
        if not path.exists():
            shutil.copytree(arena / "session", path)
    elif name == "<run-copy>":
        path = work / "run"
        if not path.exists():
            shutil.copytree(arena / "run", path)
    elif name in _CONFIG_TEXT:
        path = work / f"{name.strip('<>')}.toml"
        path.write_text(_CONFIG_TEXT[name])
    else:
        raise AssertionError(f"unknown path token {token}")
    return f"{path}{rest}"


def _flag(name: str) -> st.SearchStrategy[list[str]]:
    return st.sampled_from([[], [name]])


def _option(name: str, *values: str) -> st.SearchStrategy[list[str]]:
    return st.one_of(st.just([]), st.sampled_from(values).map(lambda v: [name, v]))


def _join(*parts: st.SearchStrategy[list[str]]) -> st.SearchStrategy[list[str]]:
    return st.tuples(*parts).map(lambda lists: [item for part in lists for item in part])


_input = st.sampled_from(INPUTS)
_output = st.sampled_from(OUTPUTS)
_config = _option("--config", *CONFIGS)

RUN = _join(
    st.just(["run"]),
    st.sampled_from(["<session>", "<sample>", "<missing>", "<file>", "<empty>", "<run>"]).map(
        lambda p: [p]
    ),
    _output.map(lambda p: ["-o", p]),
    st.just(["--no-figures"]),
    _config,
    _flag("--force"),
    _flag("-q"),
    _option("--bogus", "1"),
)
REPORT = _join(
    st.just(["report"]),
    st.sampled_from(["<run>", "<run-copy>", "<session>", "<missing>", "<file>", "<empty>"]).map(
        lambda p: [p]
    ),
    _option("--format", "terminal", "csv", "md", "latex", "html", ""),
    _option("-o", "<new>", "<nested>", "<file>", "<under-file>", "<empty>", "<locked>/t.tex"),
    _option("--metrics", "max,rmse", "snr_db", "nope", ",", ""),
    _option("--pairs", "A-B", "B-A", "Z-Z", ""),
    _option("--platforms", "A", "Q", ""),
    _option("--dpi", "50", "10", "abc"),
    _flag("--html"),
)
VALIDATE = _join(st.just(["validate"]), _input.map(lambda p: [p]), _flag("-q"))
INFO = _join(st.just(["info"]), _input.map(lambda p: [p]))
CONFIG = _join(st.just(["config"]), _config)
LOCATE = _join(
    st.just(["locate"]),
    st.sampled_from(["<session>", "<missing>", "<file>", "<empty>"]).map(lambda p: [p]),
    st.sampled_from(["A", "B", "Z", ""]).map(lambda t: ["--target", t]),
    st.sampled_from(["B", "A", "A,B", "Z", ",", ""]).map(lambda a: ["--aux", a]),
    _output.map(lambda p: ["-o", p]),
    st.sampled_from(["<good-config>", "<bad-toml>", "<unknown-key>", "<bad-value>"]).map(
        lambda c: ["--config", c]
    ),
    _option("--seed", "1", "-3", "x"),
    st.just(["--no-figures"]),
    _flag("--force"),
)
SIMULATE = _join(
    st.just(["simulate"]),
    _output.map(lambda p: [p]),
    st.sampled_from(["paper-table1", "anchors", "nav-gaps", "nope"]).map(
        lambda s: ["--scenario", s]
    ),
    st.sampled_from(["60", "20", "0", "-5", "nan", "abc"]).map(lambda d: ["--duration", d]),
    _option("--platforms", "2", "1", "0"),
    _option("--seed", "3", "12345", "-1"),
    _flag("--force"),
)

INVOCATIONS = st.one_of(RUN, REPORT, VALIDATE, INFO, CONFIG, LOCATE, SIMULATE)


def _assert_clean_end(res: Result, args: list[str]) -> None:
    """Success, one ``error:`` line, or click's usage error; never a traceback."""
    shown = f"coopproc {' '.join(args)}\n{res.output}"
    assert res.exception is None or isinstance(res.exception, SystemExit), shown
    assert "Traceback" not in res.output and "internal error" not in res.output, shown
    if res.exit_code == 0:
        return
    lines = res.output.rstrip("\n").splitlines()
    assert lines, shown
    if res.exit_code == 2:  # click: usage lines, a blank line, "Error: ..."
        assert lines[-1].startswith("Error: "), shown
        assert sum(line.startswith("Error: ") for line in lines) == 1, shown
        return
    assert res.exit_code == 1, shown
    errors = [line for line in lines if line.startswith("error:")]
    if args[0] == "validate" and not errors:  # its problems, one a line, then how many
        assert res.stdout, shown
        if "-q" not in args:
            assert res.stderr == f"{len(res.stdout.splitlines())} problem(s) in {args[1]}\n"
        return
    assert errors == [lines[-1]], shown


@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(INVOCATIONS)
def test_any_invocation_ends_in_success_or_one_error_line(arena: Path, symbolic: list[str]) -> None:
    work = Path(tempfile.mkdtemp(dir=arena))
    try:
        args = [_resolve(token, arena, work) for token in symbolic]
        res = CliRunner().invoke(main, args)
        _assert_clean_end(res, args)
    finally:
        for path in [work, *work.rglob("*")]:
            if path.is_dir() and not path.is_symlink():
                path.chmod(0o755)
        shutil.rmtree(work, ignore_errors=True)
