"""The fast path of evaluation.csv / rpe.csv: the compiled statistics are numpy's bit for
bit, the tables do not depend on the row order or on how the text columns are stored, and
the edge cases (a platform without reference, missing values, one epoch, methods at other
epochs than their neighbours, gaps) give the rows the definitions say."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from coopproc.report.evaluation import AXES, error_stats, evaluation, matched_tracks
from coopproc.report.rpe import evaluation_and_rpe, rpe, rpe_errors, segments
from coopproc.report.track_kernels import error_norms


def _numpy_error_stats(d: np.ndarray) -> dict[str, float]:
    """The statistics as plain numpy expressions (the definitions of the module doc)."""
    out: dict[str, float] = {}
    for suffix, x in (("3d", np.sqrt(np.sum(d * d, axis=1))), ("h", np.hypot(d[:, 0], d[:, 1]))):
        out[f"rmse_{suffix}"] = float(np.sqrt(np.mean(x * x)))
        out[f"mean_{suffix}"] = float(np.mean(x))
        out[f"median_{suffix}"] = float(np.median(x))
        out[f"std_{suffix}"] = float(np.std(x))
        out[f"min_{suffix}"] = float(np.min(x))
        out[f"max_{suffix}"] = float(np.max(x))
    per_axis = {
        "rms": np.sqrt(np.mean(d * d, axis=0)),
        "mean": np.mean(d, axis=0),
        "std": np.std(d, axis=0),
        "min": np.min(d, axis=0),
        "max": np.max(d, axis=0),
        "absmax": np.max(np.abs(d), axis=0),
    }
    for stat, values in per_axis.items():
        out.update({f"{stat}_{a}": float(values[k]) for k, a in enumerate(AXES)})
    return out


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """The same floats, down to the sign of a zero (a CSV prints -0.000000)."""
    return bool(np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b)))


@pytest.mark.parametrize("n", [1, 2, 9, 1000, 5003])
def test_compiled_statistics_equal_numpys_bit_for_bit(n: int) -> None:
    rng = np.random.default_rng(n)
    # errors over many magnitudes (any change of the order of a sum shows), and errors
    # of exactly +-0 (numpy's reductions keep the later of equal values, sums start at 0)
    spread = rng.normal(size=(n, 3)) * np.exp(rng.normal(scale=4.0, size=(n, 3)))
    zeros = np.column_stack(  # the east minimum, the north maximum and every up a zero
        [
            rng.choice(values, size=n)
            for values in ([0.0, -0.0, 1.5], [0.0, -0.0, -1.5], [0.0, -0.0])
        ]
    )
    for d in (spread, zeros, np.full((n, 3), -0.0)):
        assert error_stats(d) == _numpy_error_stats(d)
        e3, h, stats = error_norms(d, np.zeros_like(d))
        assert _same(e3, np.sqrt(np.sum(d * d, axis=1))) and _same(h, np.hypot(d[:, 0], d[:, 1]))
        numpy_axis = [
            np.sqrt(np.mean(d * d, axis=0)),
            np.mean(d, axis=0),
            np.std(d, axis=0),
            np.min(d, axis=0),
            np.max(d, axis=0),
            np.max(np.abs(d), axis=0),
        ]
        for row, expected in enumerate(numpy_axis):
            assert _same(stats[row], expected), row
    d = spread
    ref = np.cumsum(rng.normal(size=(n, 3)), axis=0) * 3.0
    est = ref + 0.1 * d
    for length in (0.5, 7.0, 40.0):
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ref, axis=0), axis=1))])
        j = np.searchsorted(s, s + length, side="left")
        i = np.arange(s.size)[j < s.size]
        j = j[j < s.size]
        got_i, got_j = segments(ref, length)
        np.testing.assert_array_equal(got_i, i if n > 1 else [])
        np.testing.assert_array_equal(got_j, j if n > 1 else [])
        miss = (est[j] - est[i]) - (ref[j] - ref[i])
        expected = np.sqrt(np.sum(miss * miss, axis=1)) if n > 1 else np.empty(0)
        np.testing.assert_array_equal(rpe_errors(est, ref, length), expected)


def _rows(
    platform: str, method: str, t: np.ndarray, xyz: np.ndarray, error_h: object
) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "time": t,
            "platform": platform,
            "method": method,
            "east": xyz[:, 0],
            "north": xyz[:, 1],
            "up": xyz[:, 2],
            "error_h": error_h,
        }
    )


def _session() -> pd.DataFrame:
    """Platform A: reference every second with a gap (20-30 s), ``nav`` and ``di`` at the
    reference epochs, ``rn`` half a second later, one ``di`` row without error_h and one
    without east; platform B: no reference rows; platform C: one epoch."""
    t = np.concatenate([np.arange(0.0, 20.0), np.arange(30.0, 60.0)])
    path = np.column_stack([2.0 * t, np.sin(t), 0.1 * t])
    offset = np.array([0.3, -0.4, 0.2])
    di = path + offset
    di[5, 0] = np.nan
    di_h = np.full(t.size, 0.5)
    di_h[7] = np.nan
    t_rn = t + 0.5
    rn = np.column_stack([2.0 * t_rn, np.interp(t_rn, t, path[:, 1]), 0.1 * t_rn]) - offset
    one = np.array([[1.0, 2.0, 3.0]])
    return pd.concat(
        [
            _rows("A", "reference", t, path, np.nan),
            _rows("A", "nav", t, path + 0.01, 0.01),
            _rows("A", "di", t, di, di_h),
            _rows("A", "rn", t_rn, rn, 0.5),
            _rows("B", "nav", t, path, 0.2),
            _rows("C", "reference", np.array([5.0]), one, np.nan),
            _rows("C", "nav", np.array([5.0]), one + np.array([3.0, 4.0, 0.0]), 5.0),
        ],
        ignore_index=True,
    )


def test_edge_cases_give_the_defined_rows() -> None:
    ev, errors = evaluation_and_rpe(_session(), [5.0], methods=["di", "rn"])
    ev = ev.set_index(["platform", "method"])
    assert list(ev.index) == [("A", "nav"), ("A", "di"), ("A", "rn"), ("B", "nav"), ("C", "nav")]
    # di: two rows left out (no error_h, no east); rn: at its own epochs, not the
    # reference's (the epoch in the gap 19.5 s and the one after the last, 59.5 s, dropped)
    assert ev.loc[("A", "di"), "n"] == 48 and ev.loc[("A", "rn"), "n"] == 48
    for method, sign in (("di", 1.0), ("rn", -1.0)):
        means = ev.loc[("A", method), ["mean_east", "mean_north", "mean_up"]].to_numpy(float)
        np.testing.assert_allclose(means, sign * np.array([0.3, -0.4, 0.2]), atol=1e-12)
        assert ev.loc[("A", method), "std_east"] == pytest.approx(0.0, abs=1e-12)
    # a platform without reference: counted, no statistics; one epoch: std 0
    assert ev.loc[("B", "nav"), "n"] == 0 and np.isnan(ev.loc[("B", "nav"), "rmse_3d"])
    c = ev.loc[("C", "nav")]
    assert (c["n"], c["rmse_h"], c["std_h"], c["min_east"]) == (1, 5.0, 0.0, 3.0)
    seg = errors.set_index(["platform", "method"])["segments"]
    assert seg[("B", "nav")] == 0 and seg[("C", "nav")] == 0
    assert np.isnan(errors.set_index(["platform", "method"]).loc[("C", "nav"), "rmse_m"])
    assert seg[("A", "nav")] > 0
    np.testing.assert_allclose(errors.loc[errors["platform"] == "A", "max_m"], 0.0, atol=1e-9)


def test_row_order_and_text_storage_do_not_change_the_tables() -> None:
    table = _session()
    align, lengths = ("none", "se3", "yaw"), (5.0, 20.0)
    ev, errors = evaluation_and_rpe(table, lengths, align, ["di", "rn"])
    # the same tables separately, from categorical columns, and from shuffled rows
    pd.testing.assert_frame_equal(evaluation(table, align, ["di", "rn"]), ev, check_exact=True)
    pd.testing.assert_frame_equal(
        rpe(table, lengths, align, ["di", "rn"]), errors, check_exact=True
    )
    coded = table.astype({"platform": "category", "method": "category"})
    shuffled = table.sample(frac=1.0, random_state=3).reset_index(drop=True)
    for other in (coded, shuffled):
        got = evaluation_and_rpe(other, lengths, align, ["di", "rn"])
        pd.testing.assert_frame_equal(got[0], ev, check_exact=True)
        pd.testing.assert_frame_equal(got[1], errors, check_exact=True)
    # methods at the same epochs share one reference array (RPE segments cut once)
    both = table[table["method"].isin(["reference", "nav"])]
    twin = both[both["method"] == "nav"].assign(method="di")
    tracks = {(p, m): ref for p, m, _t, _e, ref in matched_tracks(pd.concat([both, twin]))}
    assert tracks[("A", "nav")].shape == (50, 3) and tracks[("A", "di")] is tracks[("A", "nav")]
