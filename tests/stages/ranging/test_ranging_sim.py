"""The ranging stage on the simulator's paper scenarios (in memory; the end-to-end tests
through ``coopproc run`` live with the pipeline)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from coopproc.sim import simulate
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.ranging.stage import RangingConfig, RangingOutput, run_ranging


def _run(scenario: str, seed: int = 0) -> tuple[pd.DataFrame, pd.DataFrame, RangingOutput]:
    sim = simulate(scenario, seed=seed)
    session = sim.session
    observed = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    cp = fuse(session, observed, FusionParams(), output="ranges").forward
    out = run_ranging(session, cp, RangingConfig())
    truth = sim.truth.distances
    ranges = out.ranges.copy()
    ranges["true"] = np.nan
    for pair, idx in ranges.groupby("pair").groups.items():
        d = truth[truth["pair"] == pair]
        ranges.loc[idx, "true"] = np.interp(
            ranges.loc[idx, "time"], d["time"].to_numpy(), d["distance"].to_numpy()
        )
    return ranges, sim.truth.nlos_events, out


def _estimate_errors(events: pd.DataFrame, truth: pd.DataFrame, method: str) -> list[float]:
    errors = []
    for _, t in truth.iterrows():
        hit = events[
            (events["pair"] == t["pair"])
            & (events["method"] == method)
            & (events["start"] <= t["end"])
            & (events["end"] >= t["start"])
        ]
        assert len(hit) >= 1, f"{method}: event {t['pair']} {t['start']} not detected"
        errors.append(abs(hit["estimate"].iloc[0] - t["realized_mean"]) / t["realized_mean"])
    return errors


def test_paper_table1() -> None:
    _, truth, out = _run("paper-table1")
    di = _estimate_errors(out.nlos_events, truth, "di")
    rn = _estimate_errors(out.nlos_events, truth, "rn")
    print("\nTable 1 (paper-table1, seed 0): NLOS estimate error against the realized mean")
    for k, (_, t) in enumerate(truth.iterrows()):
        print(
            f"  NLOS{k + 1}: realized {t['realized_mean']:.4f} m  "
            f"RN-Based {100 * rn[k]:5.2f} %  DI-Based {100 * di[k]:5.2f} %"
        )
    assert np.mean(di) <= 0.08
    assert max(di) <= 0.15
    assert np.mean(rn) > np.mean(di)


def test_paper_experiment() -> None:
    ranges, truth, out = _run("paper-experiment")
    di = _estimate_errors(out.nlos_events, truth, "di")
    assert np.mean(di) <= 0.15
    for pair, g in ranges.groupby("pair"):
        inside = np.zeros(len(g), dtype=bool)
        for _, t in truth[truth["pair"] == pair].iterrows():
            inside |= (g["time"] >= t["start"]).to_numpy() & (g["time"] <= t["end"]).to_numpy()
        assert g["nlos_flag"].to_numpy()[~inside].mean() <= 0.01, pair
        err = {m: (g[m] - g["true"]).to_numpy() for m in ("observed", "rn", "di")}
        rmse = {m: float(np.sqrt(np.mean(e**2))) for m, e in err.items()}
        peak = {m: float(np.max(np.abs(e))) for m, e in err.items()}
        if inside.any():
            assert rmse["di"] <= 0.5 * rmse["observed"], pair
            assert peak["di"] <= 0.4 * peak["observed"], pair
            assert rmse["di"] < rmse["rn"], pair
        else:
            assert rmse["di"] <= 0.7 * rmse["observed"], pair
            assert peak["di"] <= 0.7 * peak["observed"], pair


def test_paper_experiment_unknown_sigma() -> None:
    sim = simulate("paper-experiment", seed=1)
    session = replace(sim.session, config=replace(sim.session.config, uwb_sigma_m=None))
    observed = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    cp = fuse(session, observed, FusionParams(), output="ranges").forward
    out = run_ranging(session, cp, RangingConfig())
    true_noise = sim.truth.params.uwb_noise_m
    for sigma, source in out.sigma.values():
        assert source == "data"
        assert sigma == pytest.approx(true_noise, rel=0.3)
    _estimate_errors(out.nlos_events, sim.truth.nlos_events, "di")  # all detected
