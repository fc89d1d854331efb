"""Trajectory evaluation (evaluation.csv, rpe.csv, ``coopproc report --evaluate``): the
alignments recover known transforms, the statistics equal hand-computed values, the RPE
of a scaled track is its scale error, evo gives the same numbers, and the CLI works on a
real run of sample_logs, on an old run directory and on the real TIERS recording."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

from coopproc.cli import main
from coopproc.report.alignment import AlignmentError, fit_alignment
from coopproc.report.consistency import CONSISTENCY_COLUMNS
from coopproc.report.evaluation import EVALUATION_COLUMNS, evaluation, matched_tracks
from coopproc.report.evaluation_tables import evaluation_html
from coopproc.report.metrics import position_metrics
from coopproc.report.rpe import RPE_COLUMNS, rpe, rpe_errors, segments
from coopproc.report.rundir import load_run

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample_logs"
TIERS = REPO.parent / "shared" / "data" / "real" / "tiers"


def _helix(n: int = 60) -> np.ndarray:
    """A non-planar track (3-D rotations are determined by it)."""
    a = np.linspace(0.0, 3.0 * np.pi, n)
    return np.column_stack([10.0 * np.cos(a), 6.0 * np.sin(a), 0.4 * a + np.sin(3 * a)])


def _table(times: np.ndarray, tracks: dict[str, np.ndarray], platform: str = "A") -> pd.DataFrame:
    """positions.csv rows of one platform; ``tracks["reference"]`` is the reference."""
    frames = []
    for method, (east, north, up) in ((m, xyz.T) for m, xyz in tracks.items()):
        d = tracks[method] - tracks["reference"]
        h = np.nan if method == "reference" else np.hypot(d[:, 0], d[:, 1])
        columns = {"east": east, "north": north, "up": up, "error_h": h}
        frames.append(
            pd.DataFrame({"time": times, "platform": platform, "method": method, **columns})
        )
    return pd.concat(frames, ignore_index=True)


# --- alignment ------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["se3", "sim3"])
def test_umeyama_recovers_a_known_transform(kind: str) -> None:
    est = _helix()
    rot = Rotation.from_euler("ZYX", [37.0, -4.0, 6.5], degrees=True).as_matrix()
    shift, scale = np.array([12.5, -7.25, 1.5]), 1.0 if kind == "se3" else 0.97
    ref = scale * est @ rot.T + shift
    fit = fit_alignment(kind, est, ref)
    np.testing.assert_allclose(fit.rotation, rot, atol=1e-9)
    np.testing.assert_allclose(fit.translation, shift, atol=1e-9)
    assert fit.scale == pytest.approx(scale, abs=1e-12)
    np.testing.assert_allclose(fit.euler_deg(), (6.5, -4.0, 37.0), atol=1e-9)
    np.testing.assert_allclose(fit.apply(est), ref, atol=1e-9)


def test_yaw_and_se2_fit_heading_and_shift_only() -> None:
    est = _helix()
    rot = Rotation.from_euler("z", -52.0, degrees=True).as_matrix()
    ref = est @ rot.T + np.array([3.0, 4.0, -2.0])
    yaw = fit_alignment("yaw", est, ref)
    np.testing.assert_allclose(yaw.rotation, rot, atol=1e-9)
    np.testing.assert_allclose(yaw.translation, [3.0, 4.0, -2.0], atol=1e-9)
    np.testing.assert_allclose(yaw.apply(est), ref, atol=1e-9)
    se2 = fit_alignment("se2", est, ref)  # the same yaw, but the heights are not moved
    assert se2.euler_deg()[2] == pytest.approx(-52.0, abs=1e-9)
    assert se2.translation[2] == 0.0
    np.testing.assert_allclose(se2.apply(est)[:, 2] - ref[:, 2], 2.0, atol=1e-9)
    # a tilt is not a yaw: yaw fits only the heading of a tilted track
    tilted = est @ Rotation.from_euler("x", 10.0, degrees=True).as_matrix().T
    assert fit_alignment("yaw", est, tilted).euler_deg()[0] == 0.0


def test_undetermined_alignments_are_refused_and_leave_empty_rows() -> None:
    line = np.column_stack([np.arange(10.0), 2.0 * np.arange(10.0), np.zeros(10)])
    with pytest.raises(AlignmentError, match="line"):
        fit_alignment("se3", line, line + 1.0)
    with pytest.raises(AlignmentError, match="at least 3"):
        fit_alignment("sim3", line[:2], line[:2])
    with pytest.raises(ValueError, match="unknown alignment"):
        fit_alignment("se4", line, line)
    table = _table(np.arange(10.0), {"reference": line, "nav": line + 0.5})
    row = evaluation(table, ["se3"]).iloc[0]
    assert row["n"] == 10 and np.isnan(row["rmse_3d"]) and np.isnan(row["align_scale"])
    # a line still fixes the yaw (yaw, se2)
    assert evaluation(table, ["yaw"]).iloc[0]["rmse_3d"] == pytest.approx(0.0, abs=1e-9)


# --- statistics -----------------------------------------------------------------------


def test_statistics_equal_hand_computed_values() -> None:
    times = np.arange(5.0)
    ref = np.column_stack([10.0 * times, np.ones(5), np.zeros(5)])
    d = np.array([[3.0, 4.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 3.0], [-3.0, -4.0, 1.0], [0, 0, 0]])
    table = _table(times, {"reference": ref, "di": ref + d})
    # the last epoch has no reference (error_h empty): it is not evaluated
    table.loc[(table["method"] == "di") & (table["time"] == 4.0), "error_h"] = np.nan
    row = evaluation(table).iloc[0]
    assert list(evaluation(table).columns) == list(EVALUATION_COLUMNS)
    assert (row["platform"], row["method"], row["alignment"], row["n"]) == ("A", "di", "none", 4)
    e3 = np.array([np.sqrt(26.0), 1.0, 3.0, np.sqrt(26.0)])
    expected = {
        "rmse_3d": np.sqrt(62.0 / 4),
        "mean_3d": (2 * np.sqrt(26.0) + 4) / 4,
        "median_3d": (3 + np.sqrt(26.0)) / 2,
        "min_3d": 1.0,
        "max_3d": np.sqrt(26.0),
        "std_3d": np.sqrt(62.0 / 4 - ((2 * np.sqrt(26.0) + 4) / 4) ** 2),
        "rmse_h": np.sqrt(12.5),
        "mean_h": 2.5,
        "median_h": 2.5,
        "std_h": 2.5,
        "min_h": 0.0,
        "max_h": 5.0,
        "align_scale": 1.0,
        "align_yaw_deg": 0.0,
        "align_up": 0.0,
    }
    per_axis = {  # east, north, up
        "rms": (np.sqrt(4.5), np.sqrt(8.0), np.sqrt(3.0)),
        "mean": (0.0, 0.0, 1.0),
        "std": (np.sqrt(4.5), np.sqrt(8.0), np.sqrt(2.0)),
        "min": (-3.0, -4.0, -1.0),
        "max": (3.0, 4.0, 3.0),
        "absmax": (3.0, 4.0, 3.0),
    }
    for stat, values in per_axis.items():
        expected.update(
            {f"{stat}_{a}": v for a, v in zip(("east", "north", "up"), values, strict=True)}
        )
    assert np.std(e3) == pytest.approx(expected["std_3d"])
    for name, value in expected.items():
        assert row[name] == pytest.approx(value, abs=1e-12), name
    # without alignment the horizontal statistics are Table 3's
    table3 = position_metrics(table).iloc[0]
    for ours, theirs in (("rmse_h", "rmse"), ("mean_h", "mean"), ("max_h", "max")):
        assert row[ours] == pytest.approx(table3[theirs], abs=1e-12)


def test_reference_rows_are_interpolated_but_not_across_a_gap() -> None:
    t_ref = np.array([0.0, 1.0, 2.0, 3.0, 10.0, 11.0])  # a gap between 3 and 10
    ref = np.column_stack([t_ref, np.zeros(6), np.zeros(6)])
    table = _table(t_ref, {"reference": ref})
    t = np.array([0.5, 2.5, 6.0, 10.5])
    own = pd.DataFrame(
        {
            "time": t,
            "platform": "A",
            "method": "nav",
            "east": t + 0.1,
            "north": 0.0,
            "up": 0.0,
            "error_h": 0.1,
        }
    )
    [(_, _, when, est, truth)] = list(matched_tracks(pd.concat([table, own])))
    np.testing.assert_array_equal(when, [0.5, 2.5, 10.5])
    np.testing.assert_allclose(est - truth, [[0.1, 0, 0]] * 3, atol=1e-12)


# --- relative error -------------------------------------------------------------------


def test_rpe_of_a_one_percent_scale_error_is_one_percent() -> None:
    times = np.arange(201.0)  # 200 m east at 1 m per epoch
    ref = np.column_stack([times, np.full(201, 5.0), np.zeros(201)])
    est = 1.01 * ref + np.array([4.0, -3.0, 2.0])  # a shift does not change the RPE
    table = _table(times, {"reference": ref, "nav": est})
    out = rpe(table, [10, 50])
    assert list(out.columns) == list(RPE_COLUMNS)
    assert out["segments"].tolist() == [191, 151]  # starts 0..190 / 0..150
    np.testing.assert_allclose(out["mean_pct"], 1.0, atol=1e-9)
    np.testing.assert_allclose(out["max_pct"], 1.0, atol=1e-9)
    np.testing.assert_allclose(out["mean_m"], [0.1, 0.5], atol=1e-9)
    np.testing.assert_allclose(out["std_m"], 0.0, atol=1e-9)


def test_rpe_segments_follow_the_reference_path() -> None:
    ref = np.array([[0, 0, 0], [3, 0, 0], [3, 4, 0], [6, 4, 0], [6, 8, 0]], dtype=float)
    i, j = segments(ref, 7.0)  # path 0, 3, 7, 10, 14
    np.testing.assert_array_equal(np.column_stack([i, j]), [[0, 2], [1, 3], [2, 4]])
    est = ref.copy()
    est[3] += [0.0, 0.3, 0.4]  # epoch 3 off by 0.5 m: only segment (1, 3) ends or starts there
    np.testing.assert_allclose(rpe_errors(est, ref, 7.0), [0.0, 0.5, 0.0], atol=1e-12)


def test_sim3_alignment_removes_a_scale_error_from_rpe() -> None:
    ref = _helix(200) * 4.0
    table = _table(np.arange(200.0), {"reference": ref, "nav": 1.02 * ref})
    out = rpe(table, [20], ["none", "sim3"])
    i, j = segments(ref, 20.0)  # each error is 2 % of its displacement (>= 20 m of path)
    expected = 0.02 * np.linalg.norm(ref[j] - ref[i], axis=1)
    assert out["mean_m"].iloc[0] == pytest.approx(np.mean(expected), rel=1e-9)
    assert out["max_pct"].iloc[0] == pytest.approx(100 * np.max(expected) / 20.0, rel=1e-9)
    assert out["mean_pct"].iloc[1] == pytest.approx(0.0, abs=1e-9)
    assert evaluation(table, ["sim3"])["align_scale"].iloc[0] == pytest.approx(1 / 1.02)


# --- a real run of sample_logs through the CLI ----------------------------------------


def _cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.output


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("evaluation") / "run"
    code, text = _cli("run", str(SAMPLE), "-o", str(out), "--no-figures", "--quiet")
    assert code == 0, text
    return out


def test_run_writes_evaluation_and_rpe(sample_run: Path) -> None:
    ev = pd.read_csv(sample_run / "evaluation.csv")
    # the run appends the filter consistency of each method (report/consistency.py)
    assert list(ev.columns) == [*EVALUATION_COLUMNS, *CONSISTENCY_COLUMNS]
    assert set(ev["alignment"]) == {"none"}
    assert ev[["platform", "method"]].values.tolist() == [
        [p, m] for p in "ABC" for m in ("nav", "observed", "rn", "di")
    ]
    table3 = pd.read_csv(sample_run / "position_metrics.csv")
    assert ev["n"].tolist() == table3["n"].tolist()
    np.testing.assert_allclose(ev["rmse_h"], table3["rmse"], atol=2e-6)
    np.testing.assert_allclose(ev["max_h"], table3["max"], atol=2e-6)
    np.testing.assert_allclose(
        ev["rms_east"] ** 2 + ev["rms_north"] ** 2, ev["rmse_h"] ** 2, atol=1e-5
    )
    errors = pd.read_csv(sample_run / "rpe.csv")
    assert errors["segment_m"].tolist() == [10.0, 50.0, 100.0] * 12
    assert (errors["segments"] > 0).all() and np.isfinite(errors["mean_pct"]).all()
    # the DI-Based fusion beats the observed one on the followers A and C (horizontal:
    # measured 0.022 / 0.034 m and 0.026 / 0.055 m; the 3-D RMSE is mostly the height,
    # which the 2-D fusion takes from the navigation)
    rmse = ev.set_index(["platform", "method"])["rmse_h"]
    assert rmse["A", "di"] < 0.75 * rmse["A", "observed"]
    assert rmse["C", "di"] < 0.75 * rmse["C", "observed"]
    rmse_3d = ev.set_index(["platform", "method"])["rmse_3d"]
    assert rmse_3d["A", "di"] < rmse_3d["A", "observed"]
    assert rmse_3d["C", "di"] < 0.75 * rmse_3d["C", "observed"]


def test_report_evaluate_align_se3(sample_run: Path) -> None:
    code, text = _cli("report", str(sample_run), "--evaluate", "--align", "se3")
    assert code == 0, text
    assert "alignment se3" in text and "Fitted transform" in text and "over 100 m" in text
    positions = load_run(sample_run).positions
    ev = evaluation(positions, ["se3"]).set_index(["platform", "method"])
    di = next(line for line in text.splitlines() if line.strip().startswith("DI-Based"))
    assert f"{ev.loc[('A', 'di'), 'rmse_3d']:.4f}" in di  # first DI-Based row: platform A
    assert ev.loc[("A", "di"), "rmse_3d"] < ev.loc[("A", "di"), "rmse_h"] + 0.05
    code, latex = _cli(
        "report", str(sample_run), "--align", "none,sim3", "--rpe", "25", "--format", "latex"
    )
    assert code == 0 and r"\label{tab:evaluation_sim3}" in latex
    assert r"\label{tab:rpe_none_25m}" in latex and "over 50 m" not in latex
    code, csv = _cli(
        "report",
        str(sample_run),
        "--evaluate",
        "--format",
        "csv",
        "--metrics",
        "rmse_3d,mean_pct",
        "--platforms",
        "C",
    )
    assert code == 0 and csv.count("# ") == 4 and "\nC,di," in csv and "\nA," not in csv
    code, md = _cli("report", str(sample_run), "--align", "se3", "--rpe", "none", "--format",
                    "md", "--metrics", "rmse_3d,align_yaw_deg")  # fmt: skip
    assert code == 0 and md.count("**Trajectory errors") == md.count("**Fitted transform") == 1
    assert "| Platform | Method | Yaw (deg) |" in md and "Relative error" not in md


def test_report_evaluate_bad_options_are_one_line(sample_run: Path) -> None:
    for args, status, needle in (
        (["--align", "se4"], 2, "did you mean 'se3'"),
        (["--rpe", "10,-5"], 2, "'-5' is not a segment length"),
        (["--evaluate", "--metrics", "rmse_4d"], 1, "did you mean 'rmse_3d'"),
    ):
        code, text = _cli("report", str(sample_run), *args)
        assert code == status and needle in text
        assert "Traceback" not in text and sum(needle in line for line in text.splitlines()) == 1


def test_old_run_directories_still_report(sample_run: Path, tmp_path: Path) -> None:
    old = tmp_path / "old"
    shutil.copytree(sample_run, old)
    (old / "evaluation.csv").unlink()
    (old / "rpe.csv").unlink()
    run = load_run(old)
    assert run.evaluation is None and run.rpe is None
    code, text = _cli("report", str(old))
    assert code == 0 and "Table 3" in text
    assert (
        _cli("report", str(old), "--evaluate")[1]
        == _cli("report", str(sample_run), "--evaluate")[1]
    )
    section = evaluation_html(run)  # the report.html section (figures: see test_..._figures)
    assert "<h2>Evaluation</h2>" in section and 'class="rpe_none_100m"' in section


# --- evo gives the same numbers -------------------------------------------------------


def _evo_trajectory(t: np.ndarray, xyz: np.ndarray):  # type: ignore[no-untyped-def]
    from evo.core.trajectory import PoseTrajectory3D

    quat = np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1))  # positions only: identity attitude
    return PoseTrajectory3D(positions_xyz=xyz, orientations_quat_wxyz=quat, timestamps=t)


def test_evo_ape_and_rpe_agree(sample_run: Path) -> None:
    pytest.importorskip("evo")
    from evo.core import metrics
    from evo.core.units import Unit

    positions = load_run(sample_run).positions
    ours = evaluation(positions, ["none", "se3", "sim3"]).set_index(
        ["platform", "method", "alignment"]
    )
    written = pd.read_csv(sample_run / "evaluation.csv").set_index(["platform", "method"])
    for platform, method, t, est, ref in matched_tracks(positions, ("di",)):
        if method not in ("nav", "di"):  # evo is slow: the own nav and the DI-Based fusion
            continue
        traj_ref = _evo_trajectory(t, ref)
        for align, scale in (("none", None), ("se3", False), ("sim3", True)):
            traj_est = _evo_trajectory(t, est)
            if scale is not None:
                traj_est.align(traj_ref, correct_scale=scale)
            ape = metrics.APE(metrics.PoseRelation.translation_part)
            ape.process_data((traj_ref, traj_est))
            stats = ape.get_all_statistics()
            for stat in ("rmse", "mean", "max", "std", "median", "min"):
                value = ours.loc[(platform, method, align), f"{stat}_3d"]
                assert value == pytest.approx(stats[stat], abs=1e-9)
                if align == "none":  # evaluation.csv of the run: to the 1e-6 of the CSV
                    assert written.loc[(platform, method), f"{stat}_3d"] == pytest.approx(
                        stats[stat], abs=2e-6
                    )
        # evo's RPE in metres, consecutive segments chosen on the reference's path, are
        # our segments that start where the previous one ended (same errors)
        for length in (10.0, 50.0):
            rpe_evo = metrics.RPE(
                metrics.PoseRelation.translation_part,
                delta=length,
                delta_unit=Unit.meters,
                pairs_from_reference=True,
            )
            rpe_evo.process_data((traj_ref, _evo_trajectory(t, est)))
            i, j = segments(ref, length)
            ends, chain, k = dict(zip(i.tolist(), j.tolist(), strict=True)), [], 0
            while k in ends:
                chain.append(k)
                k = ends[k]
            mine = rpe_errors(est, ref, length)[np.searchsorted(i, chain)]
            np.testing.assert_allclose(mine, rpe_evo.error, atol=1e-12)


# --- the real TIERS recording ---------------------------------------------------------


@pytest.mark.skipif(not TIERS.exists(), reason="no ../shared/data/real/tiers in this checkout")
def test_real_tiers_recording_gives_finite_numbers() -> None:
    from coopproc.io import read_session

    session = read_session(TIERS)
    tables = []
    for platform, nav in session.nav.items():
        ref = session.reference.get(platform)
        if ref is not None:  # own nav against the reference at the nav epochs
            truth = ref.interpolate_within(nav.time_s)
            tracks = {"reference": truth, "nav": nav.enu_m}
            tables.append(_table(nav.time_s, tracks, platform).dropna(subset=["east"]))
    positions = pd.concat(tables, ignore_index=True)
    kinds = ["none", "se2", "yaw", "se3", "sim3"]
    ev = evaluation(positions, kinds)
    assert len(ev) == 5 * len(tables) >= 5 * 5 and (ev["n"] > 600).all()
    numbers = ev.drop(columns=["platform", "method", "alignment"]).to_numpy(dtype=float)
    assert np.isfinite(numbers).all()
    # least squares: each richer alignment leaves no larger a 3-D RMSE
    rmse = ev.pivot(index="platform", columns="alignment", values="rmse_3d")
    for poorer, richer in (("none", "yaw"), ("se2", "yaw"), ("yaw", "se3"), ("se3", "sim3")):
        assert (rmse[richer] <= rmse[poorer] + 1e-12).all()
    errors = rpe(positions, [1.0, 5.0])
    assert (errors["segments"] > 0).all() and np.isfinite(errors["mean_pct"]).all()
