"""Filter consistency (report/consistency.py, consistency_figure.py): NIS of range
innovations and NEES of INS states against chi-square bounds, the evaluation.csv columns,
the overconfidence line and the figure."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
from report_synth import make_run

from coopproc.report.consistency import (
    CONSISTENCY_COLUMNS,
    bound,
    consistency_lines,
    with_consistency,
)
from coopproc.report.consistency_figure import consistency_panels, window_means
from coopproc.report.pages import FigureOptions
from coopproc.report.rpe import evaluation_and_rpe


def _weights(scale: dict[str, float], n: int = 2000) -> pd.DataFrame:
    """range_weights.csv rows: standardized innovations N(0, scale^2) per method."""
    rng = np.random.default_rng(0)
    rows = []
    for method, s in scale.items():
        for pair in ("A-B", "B-C"):
            z = s * rng.standard_normal(n)
            rows.append(
                pd.DataFrame(
                    {
                        "time": np.arange(n, dtype=float),
                        "pair": pair,
                        "method": method,
                        "innovation": 0.1 * z,
                        "standardized": z,
                        "gamma": 1.0,
                        "rejected": 0,
                    }
                )
            )
    return pd.concat(rows, ignore_index=True)


def _states(sigma_claimed: float, n: int = 3000) -> pd.DataFrame:
    """states.csv of one INS method whose true velocity / attitude errors are 0.1 / 0.5."""
    rng = np.random.default_rng(1)
    t = np.arange(n, dtype=float) * 0.1
    ref = {c: np.sin(t / 10 + k) for k, c in enumerate(("vel_east", "vel_north", "vel_up"))}
    ref |= {"roll": np.zeros(n), "pitch": np.zeros(n), "yaw": np.full(n, 179.9)}
    est = {c: v + 0.1 * rng.standard_normal(n) for c, v in ref.items() if c.startswith("vel")}
    # yaw near +-180: the errors wrap (179.9 + 0.5 noise is -179.6, an error of 0.5)
    est |= {
        c: (v + 0.5 * rng.standard_normal(n) + 180) % 360 - 180
        for c, v in ref.items()
        if not c.startswith("vel")
    }
    sig = {
        f"sigma_{c}": np.full(n, sigma_claimed * (0.1 if c.startswith("vel") else 0.5)) for c in ref
    }
    nan = {f"sigma_{c}": np.full(n, np.nan) for c in ref}
    return pd.concat(
        [
            pd.DataFrame({"time": t, "platform": "A", "method": "reference", **ref, **nan}),
            pd.DataFrame({"time": t, "platform": "A", "method": "ins", **est, **sig}),
        ],
        ignore_index=True,
    )


def test_chi_square_bounds() -> None:
    assert bound(1) == pytest.approx(3.841, abs=1e-3) and bound(3) == pytest.approx(7.815, abs=1e-3)


def test_nis_of_a_consistent_and_an_overconfident_fusion() -> None:
    # "observed" claims the right sigma, "di" half of it (innovations twice too large)
    weights = _weights({"observed": 1.0, "di": 2.0})
    run = make_run()
    ev = with_consistency(evaluation_and_rpe(run.positions)[0], weights, None)
    assert list(ev.columns[-len(CONSISTENCY_COLUMNS) :]) == list(CONSISTENCY_COLUMNS)
    row = ev[(ev["platform"] == "B") & (ev["method"] == "observed")].iloc[0]  # A-B and B-C
    assert row["nis_n"] == 4000
    assert row["nis_mean"] == pytest.approx(1.0, abs=0.06)
    assert row["nis_above"] == pytest.approx(0.05, abs=0.012)
    di = ev[(ev["platform"] == "A") & (ev["method"] == "di")].iloc[0]
    assert di["nis_mean"] == pytest.approx(4.0, abs=0.3)
    # P(|z| > 1.96 / 2) = 0.327 for z ~ N(0, 1)
    assert di["nis_above"] == pytest.approx(0.327, abs=0.02)
    nav = ev[ev["method"] == "nav"].iloc[0]
    assert nav["nis_n"] == 0 and np.isnan(nav["nis_mean"])
    lines = consistency_lines(weights, None)
    assert len(lines) == 1 and "DI-Based fusion is overconfident: 33 %" in lines[0]


def test_nees_of_ins_states_wraps_the_attitude() -> None:
    good, bad = _states(1.0), _states(0.5)
    assert consistency_lines(None, good) == []
    lines = consistency_lines(None, bad)
    assert len(lines) == 2 and "velocity is overconfident" in lines[0]
    frame = pd.DataFrame({"platform": ["A"], "method": ["ins"]})
    row = with_consistency(frame, None, good).iloc[0]
    assert row["nees_vel_mean"] == pytest.approx(3.0, abs=0.2)
    assert row["nees_att_mean"] == pytest.approx(3.0, abs=0.2)  # not 3 + (359.x / 0.5)^2
    assert row["nees_att_above"] == pytest.approx(0.05, abs=0.015)


def test_consistency_figure_panels() -> None:
    run = dataclasses.replace(make_run(), range_weights=_weights({"observed": 1.0, "di": 2.0}))
    panels = consistency_panels(run, FigureOptions())
    assert panels is not None and list(panels.keys) == ["nis:observed", "nis:di"]
    assert panels.titles[1] == "DI-Based fusion: NIS of range innovations"
    assert consistency_panels(make_run(), FigureOptions()) is None  # no innovations
    t, x = window_means(np.arange(120.0), np.ones(120), 50)
    assert list(t) == [24.5, 74.5] and list(x) == [1.0, 1.0]
