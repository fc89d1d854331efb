"""Paper 002's experiments end to end through the CLI and files (issue 13 items 4-5):
``coopproc simulate --gnss-obs`` (a tag among four anchors, 60 s, a 3-satellite canyon),
``coopproc inject --gross`` (a 2 m UWB range error), ``coopproc run`` with a config that
keeps 5 satellites and adds a 20 m pseudorange error; the four GPS methods in
positions.csv and the tables; the robust filters keep both gross errors out, the
standard KF does not (Tables 6-7's pattern).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.gnss.tight import epoch_model, local_frame, prepare
from coopproc.io.session import read_session
from coopproc.sim.gnss_obs import default_nav_path

pytestmark = pytest.mark.skipif(
    not default_nav_path().exists(), reason="shared/data/gnss is not present"
)
PR_AT, UWB_AT = 5.0, 14.0  # seconds from the start: the pseudorange and the UWB errors


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, float]:
    root = tmp_path_factory.mktemp("tight")
    cli = CliRunner()
    sim, new, out = root / "sim", root / "gross", root / "out"
    res = cli.invoke(
        main,
        [
            "simulate", str(sim), "--scenario", "anchors", "--seed", "2", "--duration", "60",
            "--platforms", "5", "--gnss-obs", "--set", "canyon=[[10, 20, 3]]",
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    session = read_session(sim)
    start = float(session.gnss["tag"].epoch_time_s[0])
    # the highest satellite at the pseudorange error's epoch (kept by max_satellites)
    ep = prepare(session.gnss["tag"])
    k = int(np.argmin(np.abs(ep.time_s - (start + PR_AT))))
    ref = session.reference["tag"].interpolate(ep.time_s[k : k + 1])[0]
    m = epoch_model(ep, k, local_frame(session.origin_llh), ref, np.zeros(3))
    prn = int(m.prn[np.argmax(m.el)])
    res = cli.invoke(
        main, ["inject", str(sim), "-o", str(new), "--gross", "AN1-tag", f"+{UWB_AT}", "2.0"]
    )
    assert res.exit_code == 0, res.output
    config = root / "run.toml"
    config.write_text(
        '[pipeline]\nranges = []\npositions = ["fusion"]\n\n'
        '[gnss]\nmethods = ["gnss", "gnss_kf", "tight", "tight_kf"]\nmax_satellites = 5\n\n'
        f"[[gnss.gross]]\nt = {start + PR_AT}\nprn = {prn}\nmeters = 20.0\n"
    )
    res = cli.invoke(main, ["run", str(new), "-o", str(out), "--no-figures", "-c", str(config)])
    assert res.exit_code == 0, res.output
    return out, res.output, start


def _errors(out: Path, method: str) -> pd.DataFrame:
    p = pd.read_csv(out / "positions.csv")
    mine = p[(p["platform"] == "tag") & (p["method"] == method)].reset_index(drop=True)
    ref = p[(p["platform"] == "tag") & (p["method"] == "reference")]
    merged = mine.merge(ref[["time", "east", "north", "up"]], on="time", suffixes=("", "_ref"))
    d = merged[["east", "north", "up"]].to_numpy() - merged[["east_ref", "north_ref", "up_ref"]]
    merged["err"] = np.linalg.norm(d.to_numpy(), axis=1)  # 3-D, as Tables 6-7 (N, E, H)
    return merged


def test_every_gps_method_in_the_tables(run: tuple[Path, str, float]) -> None:
    out, text, _ = run
    metrics = pd.read_csv(out / "position_metrics.csv")
    tag = metrics[metrics["platform"] == "tag"].set_index("method")
    for method in ("gnss", "gnss_kf", "tight", "tight_kf"):
        assert method in tag.index and tag.loc[method, "n"] > 100
    assert tag.loc["tight", "rmse"] < tag.loc["gnss", "rmse"]
    assert "added to [pipeline] positions" in text
    assert "PDOP of the GPS geometry" in text
    states = pd.read_csv(out / "states.csv")
    assert {"gnss", "tight"} <= set(states["method"])


def _peak(out: Path, method: str, at: float, start: float) -> float:
    e = _errors(out, method)
    near = (e["time"] >= start + at) & (e["time"] <= start + at + 2.0)
    return float(e.loc[near, "err"].max())


def test_robust_filter_against_the_standard_kf(run: tuple[Path, str, float]) -> None:
    out, _, start = run
    # 20 m on a pseudorange (GPS only, 5 satellites): Table 6's pattern
    assert _peak(out, "gnss", PR_AT, start) < 1.5  # about 0.9 m before the error
    assert _peak(out, "gnss_kf", PR_AT, start) > 3.0
    # 2 m on a UWB range (3 satellites, canyon): Table 7's pattern
    assert _peak(out, "tight", UWB_AT, start) < _peak(out, "tight_kf", UWB_AT, start)
