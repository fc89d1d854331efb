"""The declared [uwb] sigma checked against the data (issue 32.3): the white noise of the
ranges (a lower bound) and their long-lag spread against the dead reckoning (an upper
bound), neither from the fusion; a figure beyond 3 x either bound is replaced with a note
saying both, unless [calibration] trust_declared; the shared sessions keep theirs."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io.session import read_session
from coopproc.model import Session
from coopproc.run.calibration_summary import calibration_facts, calibration_lines
from coopproc.run.config import RunConfig
from coopproc.run.declared_sigma import SIGMA_FACTOR, check_declared_sigma, with_sigma
from coopproc.run.pipeline import run_pipeline
from coopproc.stages.ranging.noise_bounds import sigma_bounds
from tests.stages.fusion.test_fusion import make_session

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT.parent / "shared" / "data" / "real"


def _declaring(session: Session, sigma: float | None, trust: bool = False) -> Session:
    config = dataclasses.replace(session.config, uwb_sigma_m=sigma, trust_declared=trust)
    return dataclasses.replace(session, config=config)


@pytest.fixture(scope="module")
def synthetic() -> Session:
    """300 s, three platforms, 0.08 m white range noise (no coloured part)."""
    return make_session(uwb_sigma=0.08)[0]


def test_the_bounds_bracket_the_true_noise(synthetic) -> None:
    bounds = sigma_bounds(synthetic)
    assert bounds.pairs == bounds.long_pairs == 3
    # white: each range against its neighbours, 0.08 m true (MAD of ~300 per pair)
    assert 0.065 < bounds.white_m < 0.095
    # long lags: the white part plus the followers' DR error over up to 60 s
    assert bounds.white_m < bounds.long_m < 0.2


@pytest.mark.parametrize("declared", [0.008, 0.8])
def test_a_sigma_ten_times_off_is_replaced_by_the_bound_it_breaks(synthetic, declared) -> None:
    session = _declaring(synthetic, declared)
    checked = check_declared_sigma(session)
    assert checked is not None
    bounds = checked.bounds
    side, bound = ("small", bounds.white_m) if declared < 0.08 else ("large", bounds.long_m)
    assert checked.contradicted == side and checked.used_m == bound
    assert f"the declared [uwb] sigma {declared:.3f} m" in checked.note
    assert checked.note.endswith(
        f"{bound:.3f} m used instead ([calibration] trust_declared = true keeps the declared "
        "figure)"
    )
    assert with_sigma(session, checked).config.uwb_sigma_m == bound
    facts = checked.facts()
    assert facts["declared_m"] == declared and facts["used_m"] == round(bound, 4)


def test_a_right_sigma_and_none_are_kept(synthetic) -> None:
    checked = check_declared_sigma(_declaring(synthetic, 0.08))
    assert checked is not None and checked.used_m is None and checked.note is None
    assert with_sigma(synthetic, checked) is synthetic
    assert check_declared_sigma(_declaring(synthetic, None)) is None


def test_trust_declared_keeps_it_and_says_so(synthetic) -> None:
    checked = check_declared_sigma(_declaring(synthetic, 0.008, trust=True))
    assert checked is not None and checked.contradicted == "small" and checked.used_m is None
    assert checked.note.endswith("kept as declared ([calibration] trust_declared = true)")


def test_a_tag_without_navigation_is_checked_on_the_small_side_only(synthetic) -> None:
    nav = {p: t for p, t in synthetic.nav.items() if p != "A"}
    tagged = _declaring(dataclasses.replace(synthetic, nav=nav), 10.0)
    bounds = sigma_bounds(tagged)
    assert bounds.pairs == 3 and bounds.long_pairs == 1  # B-C only
    no_nav = dataclasses.replace(synthetic, nav={})
    assert check_declared_sigma(_declaring(no_nav, 10.0)).used_m is None
    assert check_declared_sigma(_declaring(no_nav, 0.008)).contradicted == "small"


def test_the_run_uses_the_replacement_and_reports_both(synthetic) -> None:
    output = run_pipeline(_declaring(synthetic, 0.008), RunConfig())
    (note,) = [n for n in output.notes if n.startswith("the declared [uwb] sigma 0.008 m")]
    used = output.declared_sigma.used_m
    assert f"{used:.3f} m used instead" in note
    # the ranging stage took the replacement as its prior; the line says both
    assert all(cal.declared_sigma_m == used for cal in output.ranging_calibration.values())
    uwb = [line for line in calibration_lines(output) if "UWB white noise" in line]
    assert uwb and all(f"[0.008 m, contradicted: {used:.3f} m used]" in ln for ln in uwb)
    facts = calibration_facts(output)["uwb_sigma"]
    assert facts["contradicted"] == "small" and facts["factor"] == SIGMA_FACTOR


SHARED = [
    ("sample_logs", ROOT / "sample_logs", 1.81, 1.20),
    ("tiers", REAL / "tiers", 4.00, 0.67),
    ("tuc", REAL / "tuc", 1.38, 0.076),
    ("plaza2", REAL / "plaza2", 0.91, 0.018),
    ("miluv1", REAL / "miluv1", 0.65, 0.38),
    ("hanyang_los", REAL / "hanyang_los", 25.6, None),
]


@pytest.mark.parametrize(("name", "path", "white_ratio", "long_ratio"), SHARED)
def test_the_shared_sessions_keep_their_sigma(name, path, white_ratio, long_ratio) -> None:
    """The ratios the factor was chosen on (run/declared_sigma.py's docstring)."""
    if not path.is_dir():
        pytest.skip(f"{path} not here")
    checked = check_declared_sigma(read_session(path))
    assert checked is not None and checked.note is None and checked.used_m is None
    bounds = checked.bounds
    assert checked.declared_m / bounds.white_m == pytest.approx(white_ratio, rel=0.01)
    if long_ratio is None:
        assert bounds.long_pairs == 0
    else:
        assert checked.declared_m / bounds.long_m == pytest.approx(long_ratio, rel=0.02)


def test_coopproc_run_on_sample_logs_declared_ten_times_too_large(tmp_path) -> None:
    session = tmp_path / "session"
    shutil.copytree(ROOT / "sample_logs", session, ignore=shutil.ignore_patterns("mcap"))
    toml = session / "session.toml"
    toml.write_text(toml.read_text().replace("sigma = 0.15\n", "sigma = 1.5\n"))
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", str(session), "-o", str(out), "--no-figures"])
    assert result.exit_code == 0, result.output
    assert (
        "note: the declared [uwb] sigma 1.500 m is 12.0 x the largest spread of the ranges "
        "against the dead reckoning over 10-60 s (0.125 m, median of 3 pairs; contradicted "
        "beyond 3 x): 0.125 m used instead"
    ) in result.output
    assert "[1.500 m, contradicted: 0.125 m used]" in result.output
    facts = json.loads((out / "run.json").read_text())["calibration"]["uwb_sigma"]
    assert facts == {
        "declared_m": 1.5,
        "white_m": 0.0829,
        "long_lag_m": 0.1247,
        "factor": 3.0,
        "contradicted": "large",
        "used_m": 0.1247,
    }
