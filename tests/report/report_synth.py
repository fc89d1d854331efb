"""Small synthetic output tables shared by the report tests (deterministic)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from coopproc.model import (
    DI_COLUMNS,
    NLOS_ESTIMATE_COLUMNS,
    NLOS_EVENT_COLUMNS,
    POSITIONS_COLUMNS,
    RANGES_OUT_COLUMNS,
)
from coopproc.report.metrics import distance_metrics, position_metrics
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import ranges_columns
from coopproc.report.scores import nlos_event_scores, nlos_scores

T0 = 1000.0
PAIRS = ("A-B", "A-C", "B-C")
SIGMA = 0.15


def make_run(n: int = 120, seed: int = 7) -> RunTables:
    """Three pairs, one NLOS event on A-B and B-C, positions of A and C with a reference."""
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(n, dtype=float)
    ranges, di, events, estimates = [], [], [], []
    for k, pair in enumerate(PAIRS):
        ref = 18.0 + k + 2.0 * np.sin(2 * np.pi * (t - T0) / 80.0)
        noise = rng.normal(0.0, SIGMA, n)
        nlos = np.zeros(n)
        flag = np.zeros(n, dtype=int)
        est = np.zeros(n)
        if pair != "A-C":
            s, e = 30 + 10 * k, 45 + 10 * k
            nlos[s:e] = 0.5 + 0.05 * k
            flag[s:e] = 1
            est[s:e] = nlos[s] - 0.02
            events.append((pair, "di", t[s], t[e - 1], e - s, nlos[s] - 0.02))
            events.append((pair, "rn", t[s + 1], t[e - 1], e - s - 1, nlos[s] + 0.08))
            for method, off in (("di", -0.02), ("rn", 0.08)):
                for step in range(1, 4):
                    estimates.append(
                        (
                            pair,
                            method,
                            1,
                            step,
                            t[s + step - 1],
                            nlos[s] + off * step / 3 + 0.1 / step,
                        )
                    )
        observed = ref + noise + nlos
        ranges.append(
            pd.DataFrame(
                {
                    "time": t,
                    "pair": pair,
                    "observed": observed,
                    "rn": ref + 0.5 * noise + 0.2 * nlos,
                    "di": ref + 0.3 * noise,
                    "reference": ref,
                    "nlos_flag": flag,
                    "nlos_estimate": est,
                    "outlier": np.zeros(n, dtype=np.int64),
                }
            )
        )
        dref = np.concatenate([[np.nan], np.diff(ref)])
        di.append(
            pd.DataFrame(
                {
                    "time": t,
                    "pair": pair,
                    "di_dr": dref + 0.01 * np.arange(n) / n,
                    "di_cp": dref + rng.normal(0, 0.05, n),
                    "di_smoothed": dref + rng.normal(0, 0.01, n),
                    "di_reference": dref,
                }
            )
        )
    positions = []
    for j, platform in enumerate(("A", "B", "C")):
        east = 0.5 * (t - T0) + 3.0 * j
        north = 5.0 * np.sin((t - T0) / 30.0) + 2.0 * j
        positions.append(_pos(t, platform, "reference", east, north, np.nan))
        for m, scale in (("nav", 1.0), ("observed", 0.3), ("rn", 0.2), ("di", 0.15)):
            de = scale * rng.normal(0, 1, n)
            dn = scale * rng.normal(0, 1, n)
            err = np.hypot(de, dn) if platform != "B" else np.full(n, np.nan)
            positions.append(_pos(t, platform, m, east + de, north + dn, err))
    ranges_df = pd.concat(ranges, ignore_index=True)[list(RANGES_OUT_COLUMNS)]
    events_df = pd.DataFrame(events, columns=list(NLOS_EVENT_COLUMNS))
    positions_df = pd.concat(positions, ignore_index=True)[list(POSITIONS_COLUMNS)]
    sigma = dict.fromkeys(PAIRS, SIGMA)
    return RunTables(
        ranges=ranges_df,
        di=pd.concat(di, ignore_index=True)[list(DI_COLUMNS)],
        nlos_events=events_df,
        nlos_estimates=pd.DataFrame(estimates, columns=list(NLOS_ESTIMATE_COLUMNS)),
        positions=positions_df,
        metrics=distance_metrics(ranges_df),
        position_metrics=position_metrics(positions_df),
        nlos_scores=nlos_scores(ranges_df, events_df, sigma),
        nlos_event_scores=nlos_event_scores(ranges_df, events_df),
        info={
            "coopproc_version": "0.1.0",
            "start_time": "2026-01-01T00:00:00+00:00",
            "duration_s": 1.5,
            "session": {"name": "synthetic", "path": "/data/synthetic"},
            "inputs": [{"file": "ranges.csv", "sha256": "ab" * 32}],
            "sigma": {p: {"sigma_m": SIGMA, "source": "session.toml"} for p in PAIRS},
        },
    )


#: Method chains of :func:`chain_run`: (range methods, position methods), in chain order.
CHAINS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "default": (("observed", "rn", "di"), ("observed", "rn", "di")),
    "no_rn": (("observed", "di"), ("observed", "di")),
    "no_di": (("observed", "rn"), ("observed", "rn")),
    "fusion": (("observed",), ("observed",)),
    "extra": (("observed", "rn", "median", "di"), ("observed", "rn", "median", "di", "lsq")),
}


def chain_run(chain: str, *, listed: bool = True) -> RunTables:
    """:func:`make_run` as a run of another method chain (:data:`CHAINS`) would write it.

    Dropped methods lose their ranges column, positions rows, events and estimates (without
    DI, di.csv is empty; without any NLOS method nlos_flag / nlos_estimate are 0); added
    methods (``median``, ``lsq``) get a ranges column / positions rows. ``listed``: run.json
    has the ``"methods"`` key (else an older run without it).
    """
    range_methods, position_methods = CHAINS[chain]
    base = make_run()
    ranges = base.ranges.copy()
    if "median" in range_methods:
        ranges["median"] = ranges["reference"] + 0.4 * (ranges["observed"] - ranges["reference"])
    if not {"rn", "di"} & set(range_methods):
        ranges["nlos_flag"] = 0
        ranges["nlos_estimate"] = 0.0
    ranges = ranges[list(ranges_columns(range_methods))]
    events = base.nlos_events[base.nlos_events["method"].isin(range_methods)]
    estimates = base.nlos_estimates[base.nlos_estimates["method"].isin(range_methods)]
    di = base.di if "di" in range_methods else base.di.iloc[:0]
    keep = ("reference", "nav", *position_methods)
    parts = [base.positions[base.positions["method"].isin(keep)]]
    for k, method in enumerate(m for m in position_methods if m not in ("observed", "rn", "di")):
        rows = base.positions[base.positions["method"] == "observed"].copy()
        rows["method"] = method
        rows["east"] += 0.05 * (k + 1)
        rows["error_h"] *= 0.5 + 0.2 * k
        parts.append(rows)
    positions = pd.concat(parts, ignore_index=True)
    info = dict(base.info)
    if listed:
        info["methods"] = {"ranges": list(range_methods), "positions": list(position_methods)}
    events = events.reset_index(drop=True)
    return RunTables(
        ranges=ranges,
        di=di.reset_index(drop=True),
        nlos_events=events,
        nlos_estimates=estimates.reset_index(drop=True),
        positions=positions,
        metrics=distance_metrics(ranges),
        position_metrics=position_metrics(positions),
        nlos_scores=nlos_scores(ranges, events, dict.fromkeys(PAIRS, SIGMA)),
        nlos_event_scores=nlos_event_scores(ranges, events),
        info=info,
    )


def _pos(t, platform, method, east, north, err) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "time": t,
            "platform": platform,
            "method": method,
            "east": east,
            "north": north,
            "up": 0.0,
            "error_h": err,
        }
    )


#: Paper 000 Table 2 (pair, method, max, mean, rmse, snr_db, smoothness).
PAPER_TABLE2 = [
    ("A-B", "observed", 0.8348, 0.0285, 0.1404, 42.1575, 1.8831),
    ("A-B", "rn", 0.3289, -0.0255, 0.0593, 49.8267, 1.1485),
    ("A-B", "di", 0.1024, -0.0059, 0.0389, 53.3832, 1.0111),
    ("A-C", "observed", 0.1835, 0.0041, 0.0641, 51.6731, 1.2621),
    ("A-C", "rn", 0.1880, 0.0041, 0.0639, 51.6874, 1.1209),
    ("A-C", "di", 0.1096, 0.0034, 0.0401, 55.5046, 1.0056),
    ("B-C", "observed", 0.7325, 0.0345, 0.1438, 42.0586, 1.6148),
    ("B-C", "rn", 0.2653, -0.0053, 0.0608, 49.7457, 1.1337),
    ("B-C", "di", 0.1147, -0.0035, 0.0404, 53.2827, 1.0152),
]
#: Paper 000 Table 3 (platform, method, max, mean), with made-up rmse / cep columns.
PAPER_TABLE3 = [
    ("A", "observed", 0.8250, 0.2388),
    ("A", "rn", 0.5874, 0.1742),
    ("A", "di", 0.529, 0.1534),
    ("C", "observed", 0.8771, 0.2021),
    ("C", "rn", 0.6861, 0.1427),
    ("C", "di", 0.6771, 0.12),
]


def paper_run() -> RunTables:
    """A run whose metrics tables hold the numbers of paper 000 Tables 2 and 3."""
    metrics = pd.DataFrame(
        [(*row, 300) for row in PAPER_TABLE2],
        columns=["pair", "method", "max", "mean", "rmse", "snr_db", "smoothness", "n"],
    )
    pos = pd.DataFrame(
        [
            (p, m, mx, mean, 1.2 * mean, 0.8 * mean, 0.9 * mean, mean, 2.5 * mean, 600)
            for p, m, mx, mean in PAPER_TABLE3
        ],
        columns=[
            "platform",
            "method",
            "max",
            "mean",
            "rmse",
            "rms_east",
            "rms_north",
            "cep50",
            "cep95",
            "n",
        ],
    )
    scores = pd.DataFrame(
        {
            "pair": ["A-B", "A-B", "B-C", "B-C"],
            "method": ["rn", "di", "rn", "di"],
            "precision": [0.8, 0.95, 0.7, 0.9],
            "recall": [0.9, 0.9, 0.6, 1.0],
            "f1": [0.847059, 0.924324, 0.646154, 0.947368],
            "events": [2, 2, 2, 2],
            "estimate_mae": [0.0774, 0.0217, 0.0810, 0.0086],
        }
    )
    empty = pd.DataFrame()
    return RunTables(
        ranges=empty,
        di=empty,
        nlos_events=empty,
        nlos_estimates=empty,
        positions=empty,
        metrics=metrics,
        position_metrics=pos,
        nlos_scores=scores,
    )
