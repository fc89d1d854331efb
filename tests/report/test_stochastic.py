"""The stochastic analysis (paper 002 sec. 5.1; issue 14 item 6): UWB range residuals with
known white and AR(1) noise, the Allan deviation of an IMU with known noise densities, and
``coopproc report OUT --stochastic`` on runs of sample_logs and of the real TIERS session."""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from report_synth import make_run
from test_report_rundir import write_run_dir

from coopproc.cli import main
from coopproc.errors import InputError
from coopproc.report.allan import FLICKER_FACTOR, allan_frame, imu_allan, imu_toml
from coopproc.report.stochastic import (
    STOCHASTIC_COLUMNS,
    StochasticReport,
    pair_stochastics,
    slotted_acf,
    stochastic_frame,
    uwb_stochastics,
)
from coopproc.report.stochastic_format import format_stochastic
from coopproc.run.stochastic import rest_mask

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample_logs"
TIERS = REPO / ".." / "shared" / "data" / "real" / "tiers"
#: The chain that makes ranges.csv's observed, reference and nlos_flag as the default one
#: does (nlos_flag is the DI method's), without the fusions of the processed ranges.
QUICK = '[pipeline]\nranges = ["di"]\npositions = []\n'


def ranges_frame(
    t: np.ndarray, err: np.ndarray, flag: np.ndarray, pair: str = "A-B"
) -> pd.DataFrame:
    reference = 20.0 + 3.0 * np.sin(t / 50.0)
    return pd.DataFrame(
        {
            "time": t,
            "pair": pair,
            "observed": reference + err,
            "reference": reference,
            "nlos_flag": flag.astype(int),
            "nlos_estimate": 0.0,
        }
    )


def test_slotted_acf_by_hand() -> None:
    """Products binned by their time difference, not by their index difference."""
    sums, counts = slotted_acf(np.array([0.0, 1.0, 2.0, 4.0]), np.array([1.0, -1, 1, -1]), 1.0, 3)
    np.testing.assert_array_equal(sums, [4.0, -2.0, 0.0, 1.0])
    np.testing.assert_array_equal(counts, [4.0, 2.0, 2.0, 1.0])


def test_white_noise_nlos_and_outliers() -> None:
    rng = np.random.default_rng(11)
    n = 3000
    t = 1000.0 + np.arange(n)
    err = 0.05 + rng.normal(0.0, 0.1, n)
    flag = np.zeros(n, dtype=bool)
    flag[500:700] = True
    err[500:700] += 0.6  # NLOS, flagged by the run
    err[[50, 900, 2000]] += 2.0  # gross errors the run did not flag
    res = pair_stochastics("A-B", ranges_frame(t, err, flag))
    assert res is not None
    row = res.stats
    assert row.epochs == n and row.nlos_flagged == 200
    assert 3 <= int(row.outliers) <= 25  # the three + the Gaussian tail beyond 3 sigma
    assert res.residual_m.max() < 0.5  # the gross errors are out
    assert row.n == n - 200 - row.outliers
    assert row.mean == pytest.approx(0.05, abs=0.006)
    assert row.std == pytest.approx(0.1, rel=0.04)
    assert row.robust_sigma == pytest.approx(0.1, rel=0.06)
    assert abs(row.rho1) < 0.05 and not row.correlated
    assert row.gm_tau_s == 0.0 or row.gm_tau_s < 0.35
    assert row.sigma_inflated == row.std == row.sigma_suggested
    assert row.variance_suggested == pytest.approx(row.std**2)
    assert row.normal_p > 0.01 and abs(row.kurtosis) < 0.3


def test_ar1_correlation_time_on_irregular_epochs() -> None:
    """AR(1) at 2 Hz with rho 0.9: Gauss-Markov tau = -0.5 / ln 0.9 = 4.75 s, recovered
    through 10 % dropouts and a flagged 60-s span (lag bins, not index lags)."""
    rng = np.random.default_rng(5)
    n, dt, rho, sigma = 8000, 0.5, 0.9, 0.1
    w = rng.normal(0.0, sigma * math.sqrt(1 - rho * rho), n)
    err = np.empty(n)
    err[0] = rng.normal(0.0, sigma)
    for k in range(1, n):
        err[k] = rho * err[k - 1] + w[k]
    t = 50.0 + dt * np.arange(n)
    keep = rng.random(n) > 0.1
    flag = (t > 1000.0) & (t < 1060.0)
    res = pair_stochastics("A-B", ranges_frame(t[keep], err[keep], flag[keep]))
    assert res is not None
    row = res.stats
    tau = -dt / math.log(rho)
    assert row.interval_s == pytest.approx(0.5)
    assert row.rho1 == pytest.approx(rho, abs=0.02)
    assert row.gm_tau_s == pytest.approx(tau, rel=0.15)
    assert row.corr_time_s == pytest.approx(tau, rel=0.15)
    assert row.std == pytest.approx(sigma, rel=0.1)
    assert row.correlated
    expected = row.std * math.sqrt((1 + row.rho1) / (1 - row.rho1))
    assert row.sigma_inflated == pytest.approx(expected)
    assert row.sigma_inflated == pytest.approx(sigma * math.sqrt(19.0), rel=0.2)
    # the ACF itself follows rho^k
    k = np.array([2, 4, 8])
    np.testing.assert_allclose(res.acf[k], rho**k, atol=0.06)


def test_all_row_pools_about_each_pairs_mean() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(2000.0)
    frames = [
        ranges_frame(t, bias + rng.normal(0.0, 0.1, t.size), np.zeros(t.size), pair)
        for pair, bias in (("A-B", 0.3), ("B-C", -0.2))
    ]
    pairs, notes = uwb_stochastics(pd.concat(frames, ignore_index=True))
    assert notes == [] and [p.pair for p in pairs] == ["A-B", "B-C", "all"]
    table = stochastic_frame(pairs)
    assert list(table.columns) == list(STOCHASTIC_COLUMNS)
    every = table.set_index("pair").loc["all"]
    assert every["std"] == pytest.approx(0.1, rel=0.04)  # the biases are not noise
    assert every["mean"] == pytest.approx(0.05, abs=0.005)
    assert every["rms"] == pytest.approx(math.sqrt(0.01 + (0.09 + 0.04) / 2), rel=0.03)
    assert every["n"] == table["n"].iloc[:2].sum()
    few = ranges_frame(t[:5], np.zeros(5), np.zeros(5), "C-D")
    _, notes = uwb_stochastics(pd.concat([frames[0], few], ignore_index=True))
    assert notes == [
        "C-D: fewer than 10 line-of-sight epochs with a reference distance; left out of the "
        "stochastic analysis"
    ]


def test_formats_and_the_toml_to_paste() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(500.0)
    pairs, _ = uwb_stochastics(ranges_frame(t, rng.normal(0.0, 0.12, t.size), np.zeros(t.size)))
    report = StochasticReport(tuple(pairs))
    text = format_stochastic(report, "terminal")
    snippet = text[text.index("[uwb]") :]
    assert tomllib.loads(snippet)["uwb"]["sigma"] == round(pairs[0].stats.std, 4)
    assert "# white: lag-1 autocorrelation" in snippet
    csv = format_stochastic(report, "csv")
    assert csv.startswith("# UWB range residuals on line-of-sight epochs (paper 002 sec. 5.1)\n")
    assert re.search(r"\nA-B,\d+,0\.\d+,0\.1\d+,", csv) and "# [uwb]" in csv
    latex = format_stochastic(report, "latex")
    assert r"\label{tab:stochastic}" in latex and r"\toprule" in latex and "% [uwb]" in latex
    assert "```toml\n[uwb]\n" in format_stochastic(report, "md")


# --- Allan deviation ------------------------------------------------------------------


def synthetic_imu(seconds: float = 600.0, fs: float = 100.0, seed: int = 9):
    """White noise of known density (ARW 0.0035 deg/sqrt(s), VRW 0.0006 (m/s)/sqrt(s),
    sample std = density x sqrt(fs)) plus a bias random walk whose Allan minimum falls at
    tau* = sqrt(3) N / K = 30 s."""
    rng = np.random.default_rng(seed)
    n = int(seconds * fs)
    ng, na = math.radians(0.0035), 0.0006
    kg, ka = ng * math.sqrt(3) / 30.0, na * math.sqrt(3) / 30.0
    walk = rng.normal(0.0, 1.0 / math.sqrt(fs), (n, 6)).cumsum(axis=0)
    gyro = rng.normal(0.0, ng * math.sqrt(fs), (n, 3)) + kg * walk[:, :3]
    accel = rng.normal(0.0, na * math.sqrt(fs), (n, 3)) + ka * walk[:, 3:]
    accel[:, 2] += 9.80665
    return np.arange(n) / fs, gyro, accel, (ng, kg, na, ka)


def test_allan_recovers_arw_and_vrw() -> None:
    t, gyro, accel, (ng, kg, na, ka) = synthetic_imu()
    res = imu_allan("A", "synthetic", t, gyro, accel)
    frame = allan_frame([res])
    gyros = frame[frame["sensor"] == "gyro"]
    accels = frame[frame["sensor"] == "accel"]
    np.testing.assert_allclose(gyros["random_walk"], 0.0035, rtol=0.1)
    np.testing.assert_allclose(gyros["random_walk_per_hour"], 0.0035 * 60, rtol=0.1)
    np.testing.assert_allclose(accels["random_walk"], 0.0006, rtol=0.1)
    for axis in res.axes:  # the minimum of sqrt(N^2/tau + K^2 tau/3), where it should be
        n, k = (ng, kg) if axis.sensor == "gyro" else (na, ka)
        assert axis.minimum == pytest.approx(math.sqrt(2 * n * k / math.sqrt(3)), rel=0.35)
        assert 10.0 <= axis.tau_min_s <= 60.0
    g = res.axes[0]
    assert g.bias_instability == pytest.approx(math.degrees(g.minimum / FLICKER_FACTOR) * 3600)
    a = res.axes[3]
    assert a.bias_instability == pytest.approx(a.minimum / FLICKER_FACTOR / 9.80665 * 1000)
    figures = tomllib.loads(imu_toml(res))["platforms"]["A"]["imu"]
    assert figures["gyro_noise"] == pytest.approx(gyros["random_walk"].max(), rel=1e-3)
    assert figures["accel_bias"] == pytest.approx(accels["bias_instability"].max(), rel=1e-3)
    assert res.notes == ()


def test_allan_uses_the_longest_stretch_at_rest_without_a_gap() -> None:
    t, gyro, accel, _ = synthetic_imu(seconds=120.0)
    t = np.where(t >= 30.0, t + 5.0, t)  # a 5-s gap after 30 s
    rest = np.ones(t.size, dtype=bool)
    rest[(t > 80.0) & (t < 90.0)] = False  # 10 s in motion
    res = imu_allan("B", "imu_B.csv", t, gyro, accel, rest)
    assert res.duration_s == pytest.approx(45.0, abs=0.02)  # 35..80 s
    assert res.notes == (
        "imu_B.csv: Allan deviation of the longest stretch at rest without a gap, 45.0 s "
        "(35.0-80.0; at rest 110.0 s of 125.0 s in all, judged from the IMU)",
    )
    assert res.static_fraction == pytest.approx(110.0 / 125.0, abs=1e-3)


# --- the command, on real runs --------------------------------------------------------


def _cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.output


def _quick_run(session: Path, out: Path) -> Path:
    config = out.parent / "quick.toml"
    config.write_text(QUICK)
    code, text = _cli("run", str(session), "-o", str(out), "--config", str(config),
                      "--no-figures", "--quiet")  # fmt: skip
    assert code == 0, text
    return out


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _quick_run(SAMPLE, tmp_path_factory.mktemp("stochastic") / "sample")


def test_cli_recovers_the_sample_logs_noise(sample_run: Path, tmp_path: Path) -> None:
    """sample_logs: white UWB noise 0.08 m (truth/params.toml uwb_noise_m), references with
    1 cm horizontal noise each: about 0.08 m on LOS epochs, uncorrelated."""
    code, text = _cli("report", str(sample_run), "--stochastic")
    assert code == 0, text
    table = pd.read_csv(sample_run / "stochastic.csv").set_index("pair")
    assert list(table.index) == ["A-B", "A-C", "B-C", "all"]
    assert table.loc["all", "std"] == pytest.approx(0.0812, abs=0.004)
    np.testing.assert_allclose(table["std"], 0.08, rtol=0.08)
    assert (table["correlated"] == 0).all() and (table["rho1"].abs() < 0.1).all()
    assert (
        table.loc["A-C", "nlos_flagged"] == 0
        and (table.loc[["A-B", "B-C"], "nlos_flagged"] > 30).all()
    )
    assert f"sigma = {table.loc['all', 'std']:.4f}" in text
    assert "Table 2" not in text  # the stochastic tables instead
    # an IMU file given explicitly, the tables as CSV to a file; of a platform D without
    # navigation (C's navigation moves: its IMU would be judged not at rest, and refused)
    t, gyro, accel, _ = synthetic_imu(seconds=120.0)
    imu = tmp_path / "imu_D.csv"
    pd.DataFrame(
        np.column_stack([t + 108000.0, gyro, accel]),
        columns=["time", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"],
    ).to_csv(imu, index=False, float_format="%.9f")
    target = tmp_path / "stochastic.txt"
    code, text = _cli("report", str(sample_run), "--imu", str(imu), "--format", "csv",
                      "-o", str(target))  # fmt: skip
    assert code == 0, text
    written = target.read_text()
    assert "# Gyro Allan deviation\n" in written and "# [platforms.D.imu]" in written
    allan = pd.read_csv(sample_run / "allan.csv")
    assert allan["platform"].tolist() == ["D"] * 6
    np.testing.assert_allclose(allan["random_walk"].iloc[:3], 0.0035, rtol=0.15)


@pytest.mark.slow  # every figure drawn for the page
def test_cli_figures_and_html(tmp_path: Path) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    code, text = _cli("report", str(out), "--stochastic", "--plots", "--dpi", "50", "--html")
    assert code == 0, text
    for name in ("uwb_acf", "uwb_pdf"):
        assert f"wrote {out / 'figures' / name}.png" in text
    assert not (out / "figures" / "allan.png").exists()  # no IMU data
    page = (out / "report.html").read_text()
    assert '<h2 id="stochastic">Stochastic analysis</h2>' in page
    images = re.findall(r'<img alt="(\w+)"', page)
    assert images[-2:] == ["uwb_acf", "uwb_pdf"]


def test_cli_table_and_errors(tmp_path: Path) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    code, text = _cli("report", str(out), "--stochastic", "--table")  # both, Table 2 first
    assert code == 0 and text.index("UWB range residuals") > 0 and text.startswith("Table 2.")
    twice = ("--imu", str(tmp_path / "imu_A.csv"), "--imu", str(tmp_path / "x" / "imu_A.csv"))
    code, text = _cli("report", str(out), *twice)
    assert code == 1 and text == (
        f"error: {tmp_path / 'x' / 'imu_A.csv'}: second IMU file for platform A (first: "
        f"{tmp_path / 'imu_A.csv'}); give one\n"
    )
    bad = tmp_path / "imu_A.csv"
    bad.write_text("time,gyro_x,gyro_y,gyro_z,accel_x,accel_y\n0,0,0,0,0,1\n")
    code, text = _cli("report", str(out), "--imu", str(bad))
    assert code == 1
    assert text == (
        f"error: {bad}: missing column 'accel_z'; found time, gyro_x, gyro_y, gyro_z, "
        "accel_x, accel_y\n"
    )


@pytest.mark.slow
@pytest.mark.skipif(not TIERS.exists(), reason="../shared/data (real TIERS session) is absent")
def test_tiers_real_ranges(tmp_path: Path) -> None:
    """The real TIERS ranges: its README's [uwb] sigma = 0.121 m is the std against the
    mocap truth outside the truth NLOS spans; ours, on the run's LOS epochs about each
    pair's bias, measured 0.112 m. The errors are correlated (rho1 0.5-0.95 at ~7 Hz) and
    the pairs with tb4 (body shadowing) have the largest biases."""
    out = _quick_run(TIERS, tmp_path / "tiers")
    code, text = _cli("report", str(out), "--stochastic")
    assert code == 0, text
    table = pd.read_csv(out / "stochastic.csv").set_index("pair")
    every = table.loc["all"]
    assert 0.09 <= every["sigma_suggested"] <= 0.14
    assert (table["correlated"] == 1).all() and (table["rho1"] > 0.45).all()
    assert every["sigma_inflated"] > 2.5 * every["std"]
    biased = table["mean"].drop("all").nlargest(3).index
    assert all("tb4" in pair for pair in biased)
    # the README's figure from the same residuals on the truth's LOS epochs
    ranges = pd.read_csv(out / "ranges.csv").dropna(subset=["reference"])
    spans = pd.read_csv(TIERS / "truth" / "nlos.csv")
    nlos = np.zeros(len(ranges), dtype=bool)
    for span in spans.itertuples():
        nlos |= (
            (ranges["pair"] == span.pair)
            & (ranges["time"] >= span.start)
            & (ranges["time"] <= span.end)
        ).to_numpy()
    err = (ranges["observed"] - ranges["reference"]).to_numpy()[~nlos]
    assert float(np.std(err, ddof=1)) == pytest.approx(0.121, abs=0.003)


def _cart_imu(seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A handcart-like record at 100 Hz: 20 s at rest, a 5-s turn at 0.38 rad/s, then 35 s
    straight at constant speed without vibration (its IMU reads like one at rest); and
    the track's speed per 1-s window (0 at rest, 0.8 m/s after)."""
    t, gyro, accel, _ = synthetic_imu(seconds=60.0, seed=seed)
    turn = (t >= 20.0) & (t < 25.0)
    gyro[turn, 2] += 0.38
    speed = np.where(np.arange(60) < 20, 0.0, 0.8)
    return t, gyro, accel, speed


def test_rest_is_judged_by_the_imu_and_the_track() -> None:
    t, gyro, accel, speed = _cart_imu()
    alone = rest_mask(t, gyro, accel)
    assert not alone[(t >= 20.0) & (t < 25.0)].any()  # the turn is seen by the gyros
    assert alone[t < 20.0].all() and alone[t >= 25.0].all()  # straight motion is not
    with_track = rest_mask(t, gyro, accel, speed)
    assert with_track[t < 20.0].all() and not with_track[t >= 20.0].any()
    res = imu_allan("cart", "imu_cart.csv", t, gyro, accel, with_track, judged="nav")
    assert res.duration_s == pytest.approx(19.99, abs=0.01)
    assert res.static_fraction == pytest.approx(20.0 / 60.0, abs=0.01)
    assert res.notes == (
        "imu_cart.csv: Allan deviation of the longest stretch at rest without a gap, 20.0 s "
        "(0.0-20.0; at rest 20.0 s of 60.0 s in all, judged from nav)",
    )
    np.testing.assert_allclose([a.random_walk for a in res.axes[:3]], 0.0035, rtol=0.2)
    with pytest.raises(InputError) as err:  # too short for tau = 5 s
        imu_allan("cart", "imu_cart.csv", t, gyro, accel, with_track, tau_s=5.0, judged="nav")
    assert str(err.value) == (
        "imu_cart.csv: at rest for 20.0 s at most in one stretch (20.0 s of 60.0 s in all, "
        "judged from nav); the Allan deviation to tau = 5 s needs 50 s at rest in one "
        "stretch: record the IMU at rest for its noise figures, or ask for a shorter "
        "--allan-tau"
    )


def test_cli_refuses_the_imu_of_a_moving_platform(sample_run: Path, tmp_path: Path) -> None:
    """sample_logs' C moves all along (nav_C.csv): its IMU is never at rest, whatever the
    samples say, and no figure is offered."""
    t, gyro, accel, _ = synthetic_imu(seconds=30.0)
    imu = tmp_path / "imu_C.csv"
    pd.DataFrame(
        np.column_stack([t + 108000.0, gyro, accel]),
        columns=["time", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"],
    ).to_csv(imu, index=False, float_format="%.9f")
    code, text = _cli("report", str(sample_run), "--imu", str(imu))
    assert (code, text) == (
        1,
        f"error: {imu}: never at rest in 30.0 s (judged from the IMU and the speed of "
        "nav_C.csv); the Allan deviation to tau = 1 s needs 10 s at rest in one stretch: "
        "record the IMU at rest for its noise figures, or ask for a shorter --allan-tau\n",
    )
