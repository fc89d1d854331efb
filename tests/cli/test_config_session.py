"""``coopproc config --session DIR``: the chain resolved for one session (issue 34 part 3),
the same steps ``coopproc run`` takes (run.session_chain)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from coopproc.checks.coverage import prepare_run
from coopproc.cli import main
from coopproc.io import read_session
from coopproc.run.config import load_run_config
from coopproc.run.session_chain import resolve_session
from coopproc.stages.base import CAPABILITIES, session_capabilities
from coopproc.stages.registry import POSITION_STAGES, RANGE_STAGES

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"
REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real"


def _chain(*args: str) -> list[str]:
    res = CliRunner().invoke(main, ["config", *args])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("# the chain this runs"))
    end = lines.index("", start)
    return [line.removeprefix("#   ") for line in lines[start + 1 : end]]


def test_every_stage_requires_known_capabilities() -> None:
    for stage in [*RANGE_STAGES.values(), *POSITION_STAGES.values()]:
        assert stage.requires, stage.name
        assert stage.requires <= set(CAPABILITIES), stage.name
    assert POSITION_STAGES["fusion"].requires == {"navigation"}
    assert POSITION_STAGES["lsq"].requires == {"anchors"}
    assert POSITION_STAGES["odo_uwb"].requires == {"odometer", "anchors"}


def test_sample_logs_chain_is_paper_000s() -> None:
    lines = _chain("--session", str(SAMPLE))
    assert [line.split("  ")[0] for line in lines[:4]] == [
        "1. fusion (observed)",
        "2. ranging (rn, di)",
        "3. fusion (rn)",
        "4. fusion (di)",
    ]
    assert all(line.endswith("[needs navigation]") for line in lines[:4])
    assert lines[4:] == ["session has: navigation"]


def test_a_stage_the_session_cannot_feed_is_marked(tmp_path: Path) -> None:
    cfg = tmp_path / "lsq.toml"
    cfg.write_text('[pipeline]\nranges = []\npositions = ["lsq"]\n')
    lines = _chain("-c", str(cfg), "--session", str(SAMPLE))
    assert lines[0].endswith("[needs anchors; MISSING anchors]"), lines


def test_without_session_the_chain_is_the_configs() -> None:
    lines = _chain()
    assert len(lines) == 4 and not any("needs" in line for line in lines)


def test_the_run_takes_the_resolved_steps() -> None:
    """The run's steps come from resolve_session: one resolution, not two."""
    session, _ = prepare_run(read_session(SAMPLE))
    chain = resolve_session(load_run_config(None), session)
    assert [s.label for s in chain.steps] == [
        "fusion (observed)",
        "ranging (rn, di)",
        "fusion (rn)",
        "fusion (di)",
    ]
    assert session_capabilities(session) == {"navigation"}
    assert chain.notes == ()


@pytest.mark.parametrize(
    ("name", "first", "has", "note"),
    [
        ("hanyang_los", "1. lsq (observed)", "anchors, tags", "no platform with navigation"),
        ("plaza2", "1. fusion (observed)", "anchors, navigation", "UWB-only lsq, lsq_rts"),
    ],
)
def test_real_sessions_resolve_their_families(name: str, first: str, has: str, note: str) -> None:
    if not (REAL / name).is_dir():
        pytest.skip("shared/data/real is not present")
    lines = _chain("--session", str(REAL / name))
    assert lines[0].startswith(first)
    assert f"session has: {has}" in lines
    assert any(line.startswith("note: ") and note in line for line in lines)
    if name == "hanyang_los":  # the tag's chain: UWB-only, no dead-reckoning stage
        assert not any("fusion" in line or "ranging" in line for line in lines if "needs" in line)
