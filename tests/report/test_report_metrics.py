"""Known-answer tests of the Table 2 / Table 3 statistics (DATA.md "Statistics")."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coopproc.model import METRICS_COLUMNS, POSITION_METRICS_COLUMNS
from coopproc.report.metrics import distance_metrics, distance_stats, position_metrics


def test_distance_stats_by_hand() -> None:
    # e = [0, 0.5, 1]; sum e^2 = 1.25; sum r^2 = 100 + 110.25 + 144 = 354.25
    s = distance_stats(np.array([10.0, 11.0, 13.0]), np.array([10.0, 10.5, 12.0]))
    assert s["n"] == 3
    assert s["max"] == pytest.approx(1.0)
    assert s["mean"] == pytest.approx(0.5)
    assert s["rmse"] == pytest.approx(math.sqrt(1.25 / 3))
    assert s["snr_db"] == pytest.approx(10 * math.log10(354.25 / 1.25))
    # sum diff(d)^2 = 1 + 4 = 5; sum diff(r)^2 = 0.25 + 2.25 = 2.5
    assert s["smoothness"] == pytest.approx(2.0)


def test_mean_is_signed_and_max_absolute() -> None:
    s = distance_stats(np.array([9.0, 10.0, 10.2]), np.array([10.0, 10.0, 10.0]))
    assert s["mean"] == pytest.approx(-0.8 / 3)
    assert s["max"] == pytest.approx(1.0)


def test_epochs_without_reference_or_value_are_dropped() -> None:
    d = np.array([10.0, np.nan, 12.0, 13.0, 14.0])
    r = np.array([10.0, 11.0, 11.0, np.nan, 13.0])
    s = distance_stats(d, r)
    assert s["n"] == 3  # epochs 0, 2, 4
    assert s["rmse"] == pytest.approx(math.sqrt(2 / 3))
    # consecutive epochs of the kept series: d 10, 12, 14; r 10, 11, 13
    assert s["smoothness"] == pytest.approx((4 + 4) / (1 + 4))


def test_snr_near_18m_with_014_rmse_is_42db() -> None:
    """Paper 000 Table 2, A-B observed: RMSE 0.1404 m at about 18 m gives 42.16 dB."""
    rng = np.random.default_rng(1)
    r = 18.0 + 0.05 * np.sin(np.linspace(0, 6, 400))
    z = rng.normal(size=400)
    e = 0.1404 * z / np.sqrt(np.mean(z * z))
    s = distance_stats(r + e, r)
    assert s["rmse"] == pytest.approx(0.1404, rel=1e-9)
    assert s["snr_db"] == pytest.approx(42.16, abs=0.02)


def test_undefined_statistics_are_nan_or_inf() -> None:
    empty = distance_stats(np.array([np.nan]), np.array([1.0]))
    assert empty["n"] == 0 and math.isnan(empty["rmse"])
    one = distance_stats(np.array([5.0]), np.array([5.0]))
    assert one["snr_db"] == math.inf and math.isnan(one["smoothness"])


def test_distance_metrics_rows_per_pair_and_method() -> None:
    ranges = pd.DataFrame(
        {
            "time": [2.0, 1.0, 0.0, 0.0, 1.0],
            "pair": ["B-C", "B-C", "B-C", "A-B", "A-B"],
            "observed": [13.0, 11.0, 10.0, 5.0, 5.5],
            "rn": [12.0, 10.5, 10.0, 5.0, 5.0],
            "di": [np.nan, 10.5, 10.0, 5.0, 5.0],
            "reference": [12.0, 10.5, 10.0, np.nan, 5.0],
            "nlos_flag": 0,
            "nlos_estimate": 0.0,
        }
    )
    m = distance_metrics(ranges)
    assert tuple(m.columns) == METRICS_COLUMNS
    assert list(zip(m["pair"], m["method"], strict=True)) == [
        ("A-B", "observed"),
        ("A-B", "rn"),
        ("A-B", "di"),
        ("B-C", "observed"),
        ("B-C", "rn"),
        ("B-C", "di"),
    ]
    bc_obs = m.iloc[3]
    # B-C sorted by time: d 10, 11, 13; r 10, 10.5, 12 -> the hand case above
    assert bc_obs["rmse"] == pytest.approx(math.sqrt(1.25 / 3))
    assert bc_obs["smoothness"] == pytest.approx(2.0)
    assert list(m["n"]) == [1, 1, 1, 3, 3, 2]
    assert m["n"].dtype == np.int64
    assert m.iloc[0]["max"] == pytest.approx(0.5)


def _positions() -> pd.DataFrame:
    t = [0.0, 1.0, 2.0, 3.0]
    ref = pd.DataFrame(
        {"time": t, "platform": "A", "method": "reference", "east": 0.0, "north": 0.0, "up": 0.0}
    )
    east, north = [3.0, 0.0, 3.0, 12.0], [0.0, 4.0, 4.0, 0.0]
    di = pd.DataFrame(
        {
            "time": t,
            "platform": "A",
            "method": "di",
            "east": east,
            "north": north,
            "up": 0.0,
            "error_h": np.hypot(east, north),
        }
    )
    nav = di.assign(method="nav", error_h=np.nan)
    return pd.concat([di, ref.assign(error_h=np.nan), nav], ignore_index=True)


def test_position_metrics_by_hand() -> None:
    pm = position_metrics(_positions())
    assert tuple(pm.columns[: len(POSITION_METRICS_COLUMNS)]) == POSITION_METRICS_COLUMNS
    assert list(pm["method"]) == ["nav", "di"]  # reference rows are not scored
    di = pm[pm["method"] == "di"].iloc[0]
    # error_h = 3, 4, 5, 12
    assert di["n"] == 4
    assert di["max"] == pytest.approx(12.0)
    assert di["mean"] == pytest.approx(6.0)
    assert di["rmse"] == pytest.approx(math.sqrt(194 / 4))
    assert di["cep50"] == pytest.approx(4.5)
    assert di["cep95"] == pytest.approx(5 + 0.85 * 7)
    assert di["rms_east"] == pytest.approx(math.sqrt(162 / 4))
    assert di["rms_north"] == pytest.approx(math.sqrt(32 / 4))
    nav = pm[pm["method"] == "nav"].iloc[0]
    assert nav["n"] == 0 and math.isnan(nav["max"])


def test_position_metrics_without_reference_rows_has_nan_axes() -> None:
    pos = _positions()
    pm = position_metrics(pos[pos["method"] != "reference"])
    assert math.isnan(pm.iloc[1]["rms_east"])
    assert pm.iloc[1]["rmse"] == pytest.approx(math.sqrt(194 / 4))


@given(
    st.lists(
        st.tuples(st.floats(1.0, 100.0), st.floats(-2.0, 2.0, allow_subnormal=False)),
        min_size=2,
        max_size=40,
    )
)
@settings(max_examples=60, deadline=None)
def test_invariants(pairs: list[tuple[float, float]]) -> None:
    r = np.array([p[0] for p in pairs])
    d = r + np.array([p[1] for p in pairs])
    e = d - r  # the error as represented in floating point
    s = distance_stats(d, r)
    tol = 1e-9
    assert s["max"] + tol >= s["rmse"] >= abs(s["mean"]) - tol
    # rmse^2 = mean^2 + population variance
    assert s["rmse"] ** 2 == pytest.approx(s["mean"] ** 2 + np.var(e), abs=1e-9)
    if np.any(e != 0):
        assert s["snr_db"] == pytest.approx(10 * np.log10(np.sum(r * r) / np.sum(e * e)))


def test_distance_metrics_of_shuffled_interleaved_rows_are_those_of_the_sorted_groups() -> None:
    rng = np.random.default_rng(5)
    n = 300
    frame = pd.DataFrame(
        {
            "time": np.round(rng.uniform(0, 50, n), 1),  # ties: kept in row order
            "pair": rng.choice(["B-C", "A-B", "A-C"], n),
            "observed": rng.normal(10, 1, n),
            "di": rng.normal(10, 0.5, n),
            "reference": rng.normal(10, 0.1, n),
        }
    )
    frame.loc[7, "pair"] = None  # in no pair
    got = distance_metrics(frame, methods=("observed", "di"))
    rows = []
    ordered = frame.sort_values(["pair", "time"], kind="stable")
    for pair, group in ordered.groupby("pair", sort=True):
        for method in ("observed", "di"):
            stats = distance_stats(group[method].to_numpy(), group["reference"].to_numpy())
            rows.append({"pair": pair, "method": method, **stats})
    assert (
        got["pair"].tolist() == [r["pair"] for r in rows] == ["A-B"] * 2 + ["A-C"] * 2 + ["B-C"] * 2
    )
    for column in ("max", "mean", "rmse", "snr_db", "smoothness", "n"):
        assert got[column].tolist() == [r[column] for r in rows]  # bit for bit


def _groupby_position_metrics(positions: pd.DataFrame) -> pd.DataFrame:
    """Table 3 as it was computed before integer codes: groupby and boolean masks."""
    rows = []
    for platform, group in positions.groupby("platform", sort=True, observed=True):
        refs = group[group["method"] == "reference"].sort_values("time", kind="stable")
        for method in ("nav", "observed", "di"):
            own = group[group["method"] == method].sort_values("time", kind="stable")
            h = own["error_h"].to_numpy(np.float64)
            h = h[np.isfinite(h)]
            t = own["time"].to_numpy(np.float64)
            t_ref = refs["time"].to_numpy(np.float64)
            outside = (t < t_ref[0]) | (t > t_ref[-1])
            axes = []
            for axis in ("east", "north"):
                truth = np.interp(t, t_ref, refs[axis].to_numpy(np.float64))
                truth[outside] = np.nan
                e = own[axis].to_numpy(np.float64) - truth
                e = e[np.isfinite(e)]
                axes.append(float(np.sqrt(np.mean(e * e))))
            rows.append(
                {
                    "platform": str(platform),
                    "method": method,
                    "n": h.size,
                    "max": float(np.max(h)),
                    "mean": float(np.mean(h)),
                    "rmse": float(np.sqrt(np.mean(h * h))),
                    "rms_east": axes[0],
                    "rms_north": axes[1],
                    "cep50": float(np.percentile(h, 50)),
                    "cep95": float(np.percentile(h, 95)),
                }
            )
    return pd.DataFrame(rows)


def test_position_metrics_by_codes_are_the_groupby_ones_whatever_the_row_order() -> None:
    rng = np.random.default_rng(3)
    frames = []
    for platform in ("B", "A"):
        t = np.sort(rng.uniform(0.0, 600.0, 400))
        truth = np.column_stack([np.sin(t / 50.0) * 20.0, t * 0.1, np.zeros_like(t)])
        for method, noise in (("reference", 0.0), ("nav", 1.0), ("observed", 0.2), ("di", 0.1)):
            enu = truth + rng.normal(0.0, noise, truth.shape)
            err = np.hypot(enu[:, 0] - truth[:, 0], enu[:, 1] - truth[:, 1])
            err[rng.random(err.size) < 0.05] = np.nan  # epochs without an error
            frames.append(
                pd.DataFrame(
                    {"time": t, "platform": platform, "method": method}
                    | {"east": enu[:, 0], "north": enu[:, 1], "up": enu[:, 2]}
                    | {"error_h": np.nan if method == "reference" else err}
                )
            )
    table = pd.concat(frames, ignore_index=True)
    expected = _groupby_position_metrics(table)
    grouped = table.sort_values(["platform", "method", "time"], kind="stable")
    shuffled = table.sample(frac=1.0, random_state=1)  # groups split, times out of order
    categorical = grouped.astype({"platform": "category", "method": "category"})
    for positions in (grouped, shuffled, categorical):
        got = position_metrics(positions, methods=("observed", "di"))
        pd.testing.assert_frame_equal(
            got[list(expected.columns)], expected, check_exact=True, check_dtype=False
        )
