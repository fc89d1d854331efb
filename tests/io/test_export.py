"""The export library (coopproc.io.export): row selection, the run's time base and origin
(run.json, or an older run's session.toml), and the writers on cases a sample run has
not: Unix times, one epoch, rows without a position, times that are not absolute."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc import timeconv
from coopproc.errors import ConfigError, InputError, OutputError
from coopproc.frames import geodetic2enu
from coopproc.io.export import FORMATS, RunFrame, export_tracks, run_frame, select_tracks
from coopproc.io.rtklib_pos import read_pos

ORIGIN = (34.798, 113.659, 110.0)
UNIX_T0 = 1_633_075_200.0  # 2021-10-01 08:00:00 UTC


def positions_table() -> pd.DataFrame:
    """Two platforms, methods di and nav; A.di out of time order with one row lacking a
    position; B.di a single epoch."""
    rows = [
        (UNIX_T0 + 2.0, "A", "di", 3.0, 4.0, 0.5),
        (UNIX_T0 + 0.0, "A", "di", 1.0, 2.0, 0.1),
        (UNIX_T0 + 1.0, "A", "di", np.nan, np.nan, np.nan),
        (UNIX_T0 + 1.5, "A", "di", 2.0, 3.0, 0.2),
        (UNIX_T0 + 0.0, "A", "nav", -1.0, 2.5, 0.0),
        (UNIX_T0 + 0.5, "A", "nav", -1.5, 2.5, 0.0),
        (UNIX_T0 + 0.25, "B", "di", 100.123456, -200.654321, 3.5),
    ]
    frame = pd.DataFrame(rows, columns=["time", "platform", "method", "east", "north", "up"])
    frame["error_h"] = np.nan
    return frame


def test_select_sorts_by_time_and_leaves_out_rows_without_a_position() -> None:
    tracks, notes = select_tracks(positions_table())
    assert [(t.platform, t.method, len(t.time_s)) for t in tracks] == [
        ("A", "di", 3),
        ("A", "nav", 2),
        ("B", "di", 1),
    ]
    assert np.array_equal(tracks[0].time_s, UNIX_T0 + np.array([0.0, 1.5, 2.0]))
    assert np.array_equal(tracks[0].enu_m[:, 0], [1.0, 2.0, 3.0])
    assert notes == ["A.di: 1 rows without a position left out"]


def test_select_filters_and_keeps_only_combinations_with_rows() -> None:
    tracks, _ = select_tracks(positions_table(), methods=["nav"], platforms=["B", "A"])
    assert [(t.platform, t.method) for t in tracks] == [("A", "nav")]  # B has no nav
    with pytest.raises(ConfigError, match=r"^no positions of platforms B with methods nav"):
        select_tracks(positions_table(), methods=["nav"], platforms=["B"])
    with pytest.raises(ConfigError, match=r"^--methods: unknown method 'NAV' \(did you mean 'nav'"):
        select_tracks(positions_table(), methods=["NAV"])


def frame_unix() -> RunFrame:
    return RunFrame("unix", None, ORIGIN)


def test_unix_times_go_to_gpst_in_pos_and_utc_in_geojson(tmp_path: Path) -> None:
    tracks, _ = select_tracks(positions_table(), methods=["di"], platforms=["A"])
    export_tracks(tracks, tmp_path / "p", "pos", frame_unix(), run_dir=tmp_path / "run")
    raw = read_pos(tmp_path / "p" / "A.di.pos", "A")
    np.testing.assert_allclose(timeconv.gpst_to_unix(raw.time_s), tracks[0].time_s, atol=1e-6)
    np.testing.assert_allclose(
        geodetic2enu(raw.position, ORIGIN), tracks[0].enu_m, rtol=0, atol=1e-4
    )
    export_tracks(tracks, tmp_path / "g", "geojson", frame_unix(), run_dir=tmp_path / "run")
    props = json.loads((tmp_path / "g" / "A.di.geojson").read_text())["features"][0]["properties"]
    assert props["start_utc"] == "2021-10-01T08:00:00.000Z"
    assert props["end_utc"] == "2021-10-01T08:00:02.000Z"


def test_one_epoch_is_a_point(tmp_path: Path) -> None:
    tracks, _ = select_tracks(positions_table(), platforms=["B"])
    export_tracks(tracks, tmp_path / "g", "geojson", frame_unix(), run_dir=tmp_path / "run")
    geometry = json.loads((tmp_path / "g" / "B.di.geojson").read_text())["features"][0]["geometry"]
    assert geometry["type"] == "Point"
    lon, lat, h = geometry["coordinates"]
    np.testing.assert_allclose(
        geodetic2enu([lat, lon, h], ORIGIN)[0], [100.123456, -200.654321, 3.5], atol=1e-4
    )
    export_tracks(tracks, tmp_path / "k", "kml", frame_unix(), run_dir=tmp_path / "run")
    root = ET.parse(tmp_path / "k" / "B.di.kml").getroot()
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    assert root.find("k:Document/k:Placemark/k:Point/k:coordinates", ns) is not None


def test_relative_times_have_no_utc_and_no_pos(tmp_path: Path) -> None:
    frame = RunFrame("relative", None, ORIGIN)
    tracks, _ = select_tracks(positions_table(), methods=["nav"])
    with pytest.raises(OutputError, match=r"^--format pos needs GPS times: .*'relative'"):
        export_tracks(tracks, tmp_path / "p", "pos", frame, run_dir=tmp_path / "run")
    assert not (tmp_path / "p").exists()
    export_tracks(tracks, tmp_path / "g", "geojson", frame, run_dir=tmp_path / "run")
    props = json.loads((tmp_path / "g" / "A.nav.geojson").read_text())["features"][0]["properties"]
    assert "start_utc" not in props and props["time_base"] == "relative"
    week_missing = RunFrame("gps_tow", None, ORIGIN)
    with pytest.raises(OutputError, match=r"no GPS week .* set \[time\] gps_week"):
        export_tracks(tracks, tmp_path / "p", "pos", week_missing, run_dir=tmp_path / "run")


def test_kitti_times_file_beside_the_poses(tmp_path: Path) -> None:
    tracks, _ = select_tracks(positions_table(), methods=["di"], platforms=["A"])
    written = export_tracks(tracks, tmp_path / "k", "kitti", frame_unix(), run_dir=tmp_path / "r")
    assert [p.name for p in written] == ["A.di.kitti.txt", "A.di.times.txt"]
    assert (tmp_path / "k" / "A.di.kitti.txt").read_text().splitlines()[0] == (
        "1.000000 0.000000 0.000000 1.000000 0.000000 1.000000 0.000000 2.000000 "
        "0.000000 0.000000 1.000000 0.100000"
    )
    assert (tmp_path / "k" / "A.di.times.txt").read_text().splitlines() == [
        "1633075200.000000",
        "1633075201.500000",
        "1633075202.000000",
    ]


def test_every_format_has_a_writer(tmp_path: Path) -> None:
    tracks, _ = select_tracks(positions_table(), methods=["nav"])
    for name, ext in FORMATS.items():
        written = export_tracks(tracks, tmp_path / name, name, frame_unix(), run_dir=tmp_path / "r")
        assert written[0] == tmp_path / name / f"A.nav.{ext}"
    with pytest.raises(ConfigError, match=r"unknown export format 'kmz' \(did you mean 'kml'"):
        export_tracks(tracks, tmp_path / "z", "kmz", frame_unix(), run_dir=tmp_path / "r")


def test_run_frame_from_run_json() -> None:
    info = {"session": {"time_base": "gps_tow", "gps_week": 2178, "origin_llh": list(ORIGIN)}}
    frame = run_frame(info, "run.json")
    assert (frame.time_base, frame.gps_week, frame.origin_llh) == ("gps_tow", 2178, ORIGIN)
    assert frame.gpst(np.array([1.0]))[0] == 2178 * 604800.0 + 1.0
    bad = {"session": {"time_base": "gps_tow", "gps_week": 2178, "origin_llh": [1, 2]}}
    with pytest.raises(InputError, match=r"^run.json: .*origin_llh: \[1, 2\]; expected"):
        run_frame(bad, "run.json")
    with pytest.raises(InputError, match=r"^run.json: .*time_base 'tow', gps_week None; expected"):
        run_frame({"session": {"time_base": "tow", "origin_llh": None}}, "run.json")


def test_an_older_run_json_falls_back_to_the_session_toml(tmp_path: Path) -> None:
    session = tmp_path / "session"
    session.mkdir()
    (session / "session.toml").write_text(
        '[time]\nbase = "gps_tow"\ngps_week = 2100\n[frame]\norigin = [10.0, 20.0, 30.0]\n'
    )
    frame = run_frame({"session": {"name": "s", "path": str(session)}}, "run.json")
    assert (frame.time_base, frame.gps_week, frame.origin_llh) == ("gps_tow", 2100, (10, 20, 30))
    (session / "session.toml").write_text("[frame]\norigin = [10.0, 20.0, 30.0]\n")
    frame = run_frame({"session": {"name": "s", "path": str(session)}}, "run.json")
    assert frame.time_base is None and "has no [time] base" in frame.why_no_time()
    gone = run_frame({"session": {"name": "s", "path": str(tmp_path / "gone")}}, "run.json")
    assert gone.origin_llh is None
    assert gone.no_origin.startswith("run.json records no time base or origin (written by an")
    assert gone.no_origin.endswith("rerun `coopproc run`")
