"""`coopproc run`: determinism, run.json, output-directory safety and one-line errors."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from coopproc.cli import main

TABLES = (
    "ranges.csv",
    "di.csv",
    "nlos_events.csv",
    "nlos_estimates.csv",
    "positions.csv",
    "metrics.csv",
    "position_metrics.csv",
    "nlos_scores.csv",
    "nlos_event_scores.csv",
)


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("run") / "session"
    res = CliRunner().invoke(
        main,
        ["simulate", str(path), "--scenario", "paper-table1", "--seed", "7", "--duration", "60"],
    )
    assert res.exit_code == 0, res.output
    return path


def _run(*args: str) -> tuple[int, str]:
    res = CliRunner().invoke(main, ["run", *args])
    return res.exit_code, res.output


def test_same_inputs_give_byte_identical_tables(session: Path, tmp_path: Path) -> None:
    code1, _ = _run(str(session), "-o", str(tmp_path / "a"), "--no-figures", "-q")
    code2, _ = _run(str(session), "-o", str(tmp_path / "b"), "--no-figures", "-q")
    assert code1 == code2 == 0
    for name in TABLES:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_run_json_records_inputs_config_and_summary(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    code, output = _run(str(session), "-o", str(out), "--no-figures")
    assert code == 0, output
    info = json.loads((out / "run.json").read_text())
    files = {item["file"]: item["sha256"] for item in info["inputs"]}
    assert files["ranges.csv"] == hashlib.sha256((session / "ranges.csv").read_bytes()).hexdigest()
    assert "ref_A.pos" in files and "session.toml" in files
    assert info["config"]["ranging"]["nlos"]["gamma_sigma"] == 3.0
    assert info["config"]["ranging"]["nlos"]["window_s"] == 3.0
    assert info["sigma"]["A-B"]["source"] == "data"
    assert info["sigma"]["A-B"]["sigma_m"] == pytest.approx(0.08, rel=0.3)  # simulated noise
    cal = info["calibration"]
    assert cal["ranging"]["A-B"]["di"]["declared_sigma_m"] == 0.15
    assert cal["dead_reckoning"]["A"]["drift_mps"] > 0
    assert "self-calibration (declared values in brackets):" in output
    assert info["summary"]["pairs"]["A-B"]["nlos_events"] >= 1
    assert info["duration_s"] > 0
    # the printed summary names what run.json records
    assert "NLOS events (DI-Based)" in output


def test_existing_output_needs_force_and_inputs_are_protected(
    session: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    code, output = _run(str(session), "-o", str(out), "--no-figures")
    assert code == 1
    assert output.strip().splitlines()[-1] == (
        f"error: {out}: output directory exists; use --force to replace it"
    )
    assert (out / "keep.txt").read_text() == "mine"
    code, output = _run(str(session), "-o", str(session), "--force", "--no-figures")
    assert code == 1 and "refusing to write output over the input" in output
    assert (session / "ranges.csv").exists()
    code, _ = _run(str(session), "-o", str(out), "--force", "--no-figures", "-q")
    assert code == 0
    assert not (out / "keep.txt").exists() and (out / "metrics.csv").exists()


def test_config_errors_are_one_line(session: Path, tmp_path: Path) -> None:
    cfg = tmp_path / "run.toml"
    cfg.write_text("[ranging.nlos]\ngama_sigma = 2\n")
    code, output = _run(str(session), "-o", str(tmp_path / "o"), "--config", str(cfg))
    assert code == 1
    assert output.strip() == (
        f"error: {cfg} [ranging] nlos: unknown key 'gama_sigma' (did you mean 'gamma_sigma'?)"
    )
    cfg.write_text("[fusoin]\n")
    code, output = _run(str(session), "-o", str(tmp_path / "o"), "--config", str(cfg))
    assert code == 1 and "did you mean 'fusion'?" in output and "Traceback" not in output


def test_quiet_prints_nothing(session: Path, tmp_path: Path) -> None:
    code, output = _run(str(session), "-o", str(tmp_path / "q"), "--no-figures", "-q")
    assert code == 0 and output == ""


def test_config_command_round_trips(tmp_path: Path, session: Path) -> None:
    res = CliRunner().invoke(main, ["config"])
    assert res.exit_code == 0
    assert "gamma_sigma = 3.0" in res.output
    cfg = tmp_path / "effective.toml"
    cfg.write_text(res.output)
    code, output = _run(
        str(session), "-o", str(tmp_path / "c"), "-c", str(cfg), "-q", "--no-figures"
    )
    assert code == 0, output


def test_duration_is_measured_on_a_monotonic_clock(
    session: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The system clock stepped an hour forward while the run wrote its outputs (a VM's
    clock was stepped 9 s in a day's run): duration_s and the timings are not."""
    import datetime as real_dt
    import types

    import coopproc.run.output as output

    class Stepped(real_dt.datetime):
        @classmethod
        def now(cls, tz: real_dt.tzinfo | None = None) -> real_dt.datetime:  # type: ignore[override]
            return real_dt.datetime.now(tz) + real_dt.timedelta(hours=1)

    fake = types.SimpleNamespace(**{k: getattr(real_dt, k) for k in dir(real_dt) if k[0] != "_"})
    fake.datetime = Stepped
    monkeypatch.setattr(output, "dt", fake)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(session), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    info = json.loads((out / "run.json").read_text())
    assert 0 < info["duration_s"] < 600
    assert sum(info["timings_s"].values()) == pytest.approx(info["duration_s"], abs=0.01)
    assert info["timings_s"]["other"] < 60


@pytest.mark.slow  # a run with every figure
def test_phases_are_logged_and_timings_add_up_to_the_wall_time(
    session: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(session), "-o", str(out)])
    assert res.exit_code == 0, res.output
    info = json.loads((out / "run.json").read_text())
    timings = info["timings_s"]
    phases = ["read", "prepare", "fusion (observed)", "ranging (rn, di)", "fusion (rn)"]
    phases += ["fusion (di)", "metrics", "summary", "write tables", "figures", "html", "other"]
    assert list(timings) == phases
    assert all(v >= 0 for v in timings.values())
    assert sum(timings.values()) == pytest.approx(info["duration_s"], abs=0.01)
    # not a terminal: one line per phase with its time and the elapsed time (stderr)
    for phase in phases[:-1]:
        assert f"run: {phase} done in " in res.stderr
    assert res.stderr.count("(elapsed ") == len(phases) - 1
