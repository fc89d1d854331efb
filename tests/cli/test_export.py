"""``coopproc export`` through the CLI on a run of sample_logs: every format read back
equals positions.csv, the filters, the output rules, the one-line errors, and evo's APE
on the exported TUM files."""

from __future__ import annotations

import hashlib
import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner, Result

from coopproc import timeconv
from coopproc.cli import main
from coopproc.cli.export import FORMAT_NAMES
from coopproc.frames import geodetic2enu
from coopproc.io.export import FORMATS
from coopproc.io.rtklib_pos import read_pos
from coopproc.io.tum import read_tum

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"
ORIGIN = (34.798, 113.659, 110.0)  # sample_logs/session.toml [frame] origin
WEEK = 2178  # sample_logs/session.toml [time] gps_week
METHODS = ("observed", "rn", "di", "nav", "reference")


def invoke(*args: str | Path) -> Result:
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("export") / "run"
    res = invoke("run", SAMPLE, "-o", out, "--no-figures", "-q")
    assert res.exit_code == 0, res.output
    return out


@pytest.fixture(scope="module")
def positions(run_dir: Path) -> pd.DataFrame:
    return pd.read_csv(run_dir / "positions.csv", dtype={"platform": str, "method": str})


@pytest.fixture(scope="module")
def enu_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run of a session without a geodetic anchor (ENU navigation and ranges only)."""
    root = tmp_path_factory.mktemp("enu")
    session = root / "session"
    session.mkdir()
    for f in [*SAMPLE.glob("nav_*.csv"), SAMPLE / "ranges.csv"]:
        shutil.copy(f, session / f.name)
    res = invoke("run", session, "-o", root / "run", "--no-figures", "-q")
    assert res.exit_code == 0, res.output
    return root / "run"


def tree_digest(root: Path) -> str:
    digest = hashlib.sha256()
    for p in sorted(root.rglob("*")):
        digest.update(str(p.relative_to(root)).encode())
        if p.is_file():
            digest.update(p.read_bytes())
    return digest.hexdigest()


def rows_of(positions: pd.DataFrame, platform: str, method: str) -> pd.DataFrame:
    sel = positions[(positions["platform"] == platform) & (positions["method"] == method)]
    return sel.sort_values("time", kind="stable")


def read_back(fmt: str, path: Path) -> tuple[np.ndarray | None, np.ndarray]:
    """(session times or None, ENU) of an exported file, by reading it as a tool would."""
    if fmt == "tum":
        raw = read_tum(path, "X")
        return raw.time_s, raw.position
    if fmt == "kitti":
        poses = np.loadtxt(path).reshape(-1, 3, 4)
        assert np.array_equal(poses[:, :, :3], np.broadcast_to(np.eye(3), poses[:, :, :3].shape))
        times = np.loadtxt(path.with_name(path.name.replace(".kitti.txt", ".times.txt")))
        return np.atleast_1d(times), poses[:, :, 3]
    if fmt == "pos":
        raw = read_pos(path, "X")
        assert raw.form == "llh"
        return raw.time_s - WEEK * timeconv.SECONDS_PER_WEEK, geodetic2enu(raw.position, ORIGIN)
    if fmt == "geojson":
        doc = json.loads(path.read_text())
        assert doc["type"] == "FeatureCollection" and len(doc["features"]) == 1
        geometry = doc["features"][0]["geometry"]
        assert geometry["type"] == "LineString"
        lon, lat, h = np.array(geometry["coordinates"]).T
        return None, geodetic2enu(np.column_stack([lat, lon, h]), ORIGIN)
    root = ET.parse(path).getroot()
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    text = root.find("k:Document/k:Placemark/k:LineString/k:coordinates", ns)
    assert text is not None and text.text
    lon, lat, h = np.array([c.split(",") for c in text.text.split()], dtype=float).T
    return None, geodetic2enu(np.column_stack([lat, lon, h]), ORIGIN)


#: How close a read-back position must be to positions.csv: TUM and KITTI carry its six
#: decimals; the geodetic formats 1e-9 deg (0.11 mm) and 0.1 mm in height.
TOLERANCE_M = {"tum": 1e-6, "kitti": 1e-6, "pos": 1e-4, "geojson": 1e-4, "kml": 1e-4}


def test_cli_formats_are_the_library_formats() -> None:
    assert tuple(FORMATS) == FORMAT_NAMES


@pytest.mark.parametrize("fmt", FORMAT_NAMES)
def test_every_exported_file_equals_positions_csv(
    fmt: str, run_dir: Path, positions: pd.DataFrame, tmp_path: Path
) -> None:
    before = tree_digest(run_dir)
    res = invoke("export", run_dir, "--format", fmt, "-o", tmp_path / "x")
    assert res.exit_code == 0, res.output
    assert tree_digest(run_dir) == before  # OUT never modified
    combos = positions[["platform", "method"]].drop_duplicates()
    assert len(combos) == 15 and set(combos["method"]) == set(METHODS)
    ext = FORMATS[fmt]
    expected = {f"{p}.{m}.{ext}" for p, m in combos.itertuples(index=False)}
    if fmt == "kitti":
        expected |= {f"{p}.{m}.times.txt" for p, m in combos.itertuples(index=False)}
    assert {p.name for p in (tmp_path / "x").iterdir()} == expected
    assert res.output.splitlines() == [f"wrote {tmp_path / 'x' / n}" for n in sorted(expected)]
    for pid, method in combos.itertuples(index=False):
        rows = rows_of(positions, pid, method)
        times, enu = read_back(fmt, tmp_path / "x" / f"{pid}.{method}.{ext}")
        want = rows[["east", "north", "up"]].to_numpy()
        assert enu.shape == want.shape, (pid, method)
        np.testing.assert_allclose(enu, want, rtol=0, atol=TOLERANCE_M[fmt], err_msg=method)
        if times is not None:
            np.testing.assert_allclose(times, rows["time"].to_numpy(), rtol=0, atol=1e-6)


def test_geojson_and_kml_say_what_the_track_is(
    run_dir: Path, positions: pd.DataFrame, tmp_path: Path
) -> None:
    rows = rows_of(positions, "B", "di")
    first, last = rows["time"].iloc[[0, -1]]
    res = invoke("export", run_dir, "--format", "geojson", "-o", tmp_path / "g", "--platforms", "B")
    assert res.exit_code == 0, res.output
    props = json.loads((tmp_path / "g" / "B.di.geojson").read_text())["features"][0]["properties"]
    assert props["platform"] == "B" and props["method"] == "di" and props["epochs"] == len(rows)
    assert (props["start_time"], props["end_time"]) == (round(first, 6), round(last, 6))
    # gps_tow 108000 s of week 2178 is Monday 2021-10-04 06:00:00 GPST = 05:59:42 UTC
    assert props["time_base"] == "gps_tow"
    assert props["start_utc"].startswith("2021-10-04T05:59:42.")
    res = invoke("export", run_dir, "--format", "kml", "-o", tmp_path / "k", "--methods", "di")
    assert res.exit_code == 0, res.output
    root = ET.parse(tmp_path / "k" / "B.di.kml").getroot()
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    assert root.findtext("k:Document/k:Placemark/k:name", namespaces=ns) == "B di"
    begin = root.findtext("k:Document/k:Placemark/k:TimeSpan/k:begin", namespaces=ns)
    assert begin == props["start_utc"]


def test_pos_opens_like_an_rtklib_solution(run_dir: Path, tmp_path: Path) -> None:
    res = invoke("export", run_dir, "--format", "pos", "-o", tmp_path / "p", "--methods", "di")
    assert res.exit_code == 0, res.output
    lines = (tmp_path / "p" / "A.di.pos").read_text().splitlines()
    header = [s for s in lines if s.startswith("%")]
    assert header[-1].split()[1:5] == ["GPST", "latitude(deg)", "longitude(deg)", "height(m)"]
    first = lines[len(header)].split()
    assert first[0] == str(WEEK) and first[1] == "108000.013000"  # week, tow


def test_methods_and_platforms_filter(run_dir: Path, tmp_path: Path) -> None:
    res = invoke(
        "export",
        run_dir,
        "--format",
        "tum",
        "-o",
        tmp_path / "x",
        "--methods",
        "reference, di",
        "--platforms",
        "C,A",
    )
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (tmp_path / "x").iterdir()) == [
        "A.di.tum",
        "A.reference.tum",
        "C.di.tum",
        "C.reference.tum",
    ]


def test_existing_directory_needs_force(run_dir: Path, tmp_path: Path) -> None:
    target = tmp_path / "x"
    target.mkdir()
    (target / "old.txt").write_text("old")
    res = invoke("export", run_dir, "--format", "tum", "-o", target, "--methods", "di")
    assert res.exit_code == 1
    assert res.output == f"error: {target}: output directory exists; use --force to replace it\n"
    assert (target / "old.txt").exists()
    res = invoke("export", run_dir, "--format", "tum", "-o", target, "--methods", "di", "--force")
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in target.iterdir()) == ["A.di.tum", "B.di.tum", "C.di.tum"]


def test_same_run_same_bytes(run_dir: Path, tmp_path: Path) -> None:
    for fmt in FORMAT_NAMES:
        a, b = tmp_path / f"{fmt}1", tmp_path / f"{fmt}2"
        for d in (a, b):
            assert invoke("export", run_dir, "--format", fmt, "-o", d).exit_code == 0
        assert tree_digest(a) == tree_digest(b), fmt


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--methods", "dii"], "--methods: unknown method 'dii' (did you mean 'di'?)"),
        (["--platforms", "a"], "--platforms: unknown platform 'a' (did you mean 'A'?)"),
        (["--platforms", "Z"], "--platforms: unknown platform 'Z' (the run has A, B, C)"),
    ],
)
def test_unknown_names_are_one_line_errors(
    args: list[str], message: str, run_dir: Path, tmp_path: Path
) -> None:
    res = invoke("export", run_dir, "--format", "tum", "-o", tmp_path / "x", *args)
    assert res.exit_code == 1
    assert res.output == f"error: {message}\n"
    assert not (tmp_path / "x").exists()


def test_output_inside_the_run_is_refused(run_dir: Path) -> None:
    before = tree_digest(run_dir)
    for target in (run_dir / "export", run_dir):
        res = invoke("export", run_dir, "--format", "tum", "-o", target, "--force")
        assert res.exit_code == 1
        assert res.output.startswith(f"error: {target}: inside the run directory {run_dir}")
        assert len(res.output.splitlines()) == 1
    res = invoke("export", run_dir, "--format", "tum", "-o", run_dir.parent, "--force")
    assert res.exit_code == 1
    assert "refusing to write output over the input" in res.output
    assert tree_digest(run_dir) == before


def test_output_paths_that_cannot_be_are_one_line_errors(run_dir: Path, tmp_path: Path) -> None:
    (tmp_path / "afile").write_text("a file\n")
    cases = {
        tmp_path / "afile": "exists and is not a directory",
        tmp_path / "afile" / "sub": f"cannot create the output: {tmp_path / 'afile'} is not a",
        Path("/dev/null/out"): "cannot create the output: /dev/null is not a directory",
    }
    for target, problem in cases.items():
        res = invoke("export", run_dir, "--format", "tum", "-o", target)
        assert res.exit_code == 1
        assert res.output.startswith(f"error: {target}: {problem}"), res.output
        assert len(res.output.splitlines()) == 1
    res = invoke("export", run_dir, "--format", "tum", "-o", tmp_path / "a" / "b" / "new")
    assert res.exit_code == 0, res.output  # missing parents are created


def test_not_a_run_is_a_one_line_error(tmp_path: Path) -> None:
    res = invoke("export", tmp_path / "nothing", "--format", "tum", "-o", tmp_path / "x")
    assert res.exit_code == 1
    assert res.output == f"error: {tmp_path / 'nothing'}: not an output directory of coopproc run\n"


def test_run_without_geodetic_origin(enu_run: Path, tmp_path: Path) -> None:
    session = json.loads((enu_run / "run.json").read_text())["session"]
    assert session["origin_llh"] is None and session["gps_week"] is None
    for fmt in ("pos", "geojson", "kml"):
        res = invoke("export", enu_run, "--format", fmt, "-o", tmp_path / fmt)
        assert res.exit_code == 1
        assert res.output.startswith(
            f"error: --format {fmt} needs the session's geodetic origin: the session has none"
        )
        assert len(res.output.splitlines()) == 1 and not (tmp_path / fmt).exists()
    for fmt in ("tum", "kitti"):  # the ENU formats need no origin
        assert invoke("export", enu_run, "--format", fmt, "-o", tmp_path / fmt).exit_code == 0


def test_evo_ape_equals_the_run_statistics(
    run_dir: Path, positions: pd.DataFrame, tmp_path: Path
) -> None:
    pytest.importorskip("evo")
    from evo.core import metrics, sync
    from evo.core.trajectory import PoseTrajectory3D
    from evo.tools.file_interface import read_tum_trajectory_file

    res = invoke("export", run_dir, "--format", "tum", "-o", tmp_path / "t")
    assert res.exit_code == 0, res.output
    table = pd.read_csv(run_dir / "position_metrics.csv", dtype={"platform": str})

    def rmse(ref: PoseTrajectory3D, est: PoseTrajectory3D) -> float:
        ape = metrics.APE(metrics.PoseRelation.translation_part)
        ape.process_data((ref, est))
        return float(ape.get_statistic(metrics.StatisticsType.rmse))

    def flat(traj: PoseTrajectory3D) -> PoseTrajectory3D:
        xyz = traj.positions_xyz.copy()
        xyz[:, 2] = 0.0
        return PoseTrajectory3D(xyz, traj.orientations_quat_wxyz, traj.timestamps)

    for pid in ("A", "B", "C"):
        ref = read_tum_trajectory_file(str(tmp_path / "t" / f"{pid}.reference.tum"))
        est = read_tum_trajectory_file(str(tmp_path / "t" / f"{pid}.di.tum"))
        ref, est = sync.associate_trajectories(ref, est, max_diff=1e-4)
        # 3-D: from positions.csv, di and reference rows at the same times
        di = rows_of(positions, pid, "di").set_index("time")[["east", "north", "up"]]
        truth = rows_of(positions, pid, "reference").set_index("time")[["east", "north", "up"]]
        both = di.index.intersection(truth.index)
        diff = di.loc[both].to_numpy() - truth.loc[both].to_numpy()
        assert ref.num_poses == len(both)
        assert rmse(ref, est) == pytest.approx(np.sqrt((diff**2).sum(axis=1).mean()), abs=1e-9)
        # horizontal (z zeroed): the rmse of position_metrics.csv, written to 6 decimals
        row = table[(table["platform"] == pid) & (table["method"] == "di")]
        assert rmse(flat(ref), flat(est)) == pytest.approx(float(row["rmse"].iloc[0]), abs=1e-6)
