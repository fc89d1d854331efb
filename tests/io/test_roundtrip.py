"""Write -> read round trips for every format, reading to the same model."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from coopproc import frames, timeconv
from coopproc.errors import OutputError
from coopproc.io import (
    read_pos,
    read_session,
    write_mcap,
    write_pos,
    write_session,
    write_tum,
)
from coopproc.io.writers import session_to_gpst


def test_session_dir_with_pos_reference(kit: Any, tmp_path: Path) -> None:
    s = kit.make_session()
    write_session(s, tmp_path)
    r = read_session(tmp_path)
    kit.assert_same_session(s, r)
    assert r.notes == ()
    assert list(r.ranges.extra_columns) == ["rssi"]
    np.testing.assert_allclose(r.ranges.frame["rssi"], s.ranges.frame["rssi"])
    assert {p.name for p in r.inputs} >= {"session.toml", "nav_A.csv", "ranges.csv", "ref_A.pos"}
    assert r.platforms["X"].position_enu_m == (1.0, 2.0, 3.0)
    assert r.config.uwb_sigma_m == 0.15 and r.platforms["A"].drift_sigma_mps == 0.02
    np.testing.assert_array_equal(r.reference["A"].quality, 1)


def test_gzip_and_csv_reference(kit: Any, tmp_path: Path) -> None:
    s = kit.make_session()
    written = write_session(s, tmp_path, reference_format="csv", compress=True)
    assert {p.name for p in written} >= {"nav_A.csv.gz", "ranges.csv.gz", "ref_A.csv.gz"}
    kit.assert_same_session(s, read_session(tmp_path), pos_tol=2e-6)


@pytest.mark.parametrize("base", ["unix", "relative"])
def test_other_time_bases(kit: Any, tmp_path: Path, base: str) -> None:
    s = kit.make_session(time_base=base)
    fmt = "pos" if base == "unix" else "csv"
    write_session(s, tmp_path, reference_format=fmt)  # type: ignore[arg-type]
    kit.assert_same_session(s, read_session(tmp_path))


def test_relative_base_cannot_write_pos(kit: Any, tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="relative time base cannot be written"):
        write_session(kit.make_session(time_base="relative"), tmp_path)


def test_tum_nav(kit: Any, tmp_path: Path) -> None:
    s = kit.make_session(rich=False)
    write_session(s, tmp_path)
    for pid, traj in s.nav.items():
        (tmp_path / f"nav_{pid}.csv").unlink()
        write_tum(traj, tmp_path / f"nav_{pid}.tum")
    kit.assert_same_session(s, read_session(tmp_path), rich=False)


@pytest.mark.parametrize("form", ["llh", "ecef"])
def test_nav_csv_in_geodetic_and_ecef_form(kit: Any, tmp_path: Path, form: str) -> None:
    s = kit.make_session(rich=False)
    write_session(s, tmp_path)
    enu = s.nav["A"].enu_m
    if form == "llh":
        p = frames.enu2geodetic(enu, kit.ORIGIN)
        cols = {"lat": p[:, 0], "lon": p[:, 1], "height": p[:, 2]}
    else:
        p = frames.enu2ecef(enu, kit.ORIGIN)
        cols = {"x": p[:, 0], "y": p[:, 1], "z": p[:, 2]}
    frame = pd.DataFrame({"time": s.nav["A"].time_s, **cols})
    path = tmp_path / "nav_A.csv"
    path.write_text("# converted\n# by a test\n" + frame.to_csv(index=False, float_format="%.10f"))
    r = read_session(tmp_path)
    np.testing.assert_allclose(r.nav["A"].enu_m, enu, atol=2e-4)


@pytest.mark.parametrize(
    ("form", "system", "time_format"),
    [("ecef", "GPST", "calendar"), ("llh", "UTC", "calendar"), ("llh", "GPST", "week_tow")],
)
def test_pos_forms(kit: Any, tmp_path: Path, form: str, system: str, time_format: str) -> None:
    s = kit.make_session()
    write_session(s, tmp_path)
    ref = s.reference["B"]
    gpst = session_to_gpst(ref.time_s, s.config)
    pos = (
        frames.enu2ecef(ref.enu_m, kit.ORIGIN)
        if form == "ecef"
        else frames.enu2geodetic(ref.enu_m, kit.ORIGIN)
    )
    write_pos(
        tmp_path / "ref_B.pos",
        gpst,
        pos,
        form=form,  # type: ignore[arg-type]
        time_system=system,  # type: ignore[arg-type]
        time_format=time_format,  # type: ignore[arg-type]
    )
    r = read_session(tmp_path)
    np.testing.assert_allclose(r.reference["B"].time_s, ref.time_s, atol=1e-6)
    np.testing.assert_allclose(r.reference["B"].enu_m, ref.enu_m, atol=2e-4)


#: An rtkpost solution file in RTKLIB 2.4.3 layout (Q 1, 1, 2, 5, 1).
RTKLIB_FIXTURE = (Path(__file__).parent / "data" / "rtklib_kinematic.pos").read_text()


def test_rtklib_fixture_reads_with_q_and_sd(kit: Any, tmp_path: Path) -> None:
    path = tmp_path / "ref_A.pos"
    path.write_text(RTKLIB_FIXTURE)
    raw = read_pos(path, "A")
    assert raw.form == "llh" and raw.time_kind == "gpst" and raw.gps_week == kit.WEEK
    _week, tow = timeconv.gpst_to_week_tow(raw.time_s)
    np.testing.assert_allclose(tow, 432000.0 + 0.1 * np.arange(5), atol=1e-6)
    np.testing.assert_array_equal(raw.quality, [1, 1, 2, 5, 1])
    assert raw.sigma_enu_m is not None
    np.testing.assert_allclose(raw.sigma_enu_m[0], [0.0041, 0.0052, 0.0113])  # e, n, u
    assert raw.position[4, 2] == 110.004


def test_q_filter_default_and_configured(kit: Any, tmp_path: Path) -> None:
    s = kit.make_session(n_nav=5)
    write_session(s, tmp_path)
    (tmp_path / "ref_A.pos").write_text(RTKLIB_FIXTURE)
    r = read_session(tmp_path)
    np.testing.assert_allclose(r.reference["A"].time_s, [432000.0, 432000.1, 432000.4])
    assert any("2 of 5 epochs with Q not in [1]" in n for n in r.notes)
    toml = tmp_path / "session.toml"
    toml.write_text(toml.read_text() + "\n[reference]\nquality = [1, 2]\n")
    r2 = read_session(tmp_path)
    np.testing.assert_array_equal(r2.reference["A"].quality, [1, 1, 2, 1])
    # The first fix is the origin: (34.798, 113.659, 110) -> ENU 0 there.
    np.testing.assert_allclose(r2.reference["A"].enu_m[0], [0, 0, 0], atol=1e-6)


def test_origin_and_week_defaults_without_toml_keys(kit: Any, tmp_path: Path) -> None:
    s = kit.make_session()
    write_session(s, tmp_path)
    (tmp_path / "session.toml").write_text('[platforms.X]\nrole = "anchor"\nposition = [1, 2, 3]\n')
    r = read_session(tmp_path)
    first_a = frames.enu2geodetic(s.reference["A"].enu_m[:1], kit.ORIGIN)[0]
    np.testing.assert_allclose(r.origin_llh, first_a, atol=1e-9)
    np.testing.assert_allclose(r.reference["A"].enu_m[0], 0.0, atol=1e-6)
    assert r.config.time_base == "gps_tow" and r.config.gps_week == kit.WEEK
    joined = "\n".join(r.notes)
    assert "[time] base not given: gps_tow" in joined
    assert f"gps_week not given: week {kit.WEEK}" in joined
    assert "first reference fix of A" in joined
    assert "no role given for A, B, C: follower assumed" in joined


def test_unsorted_and_duplicated_rows_are_sorted_and_noted(kit: Any, tmp_path: Path) -> None:
    s = kit.make_session(n_nav=20)
    write_session(s, tmp_path)
    nav = tmp_path / "nav_A.csv"
    lines = nav.read_text().splitlines()
    body = lines[1:]
    body[3], body[4] = body[4], body[3]
    nav.write_text("\n".join([lines[0], *body, body[-1]]) + "\n")
    rng = tmp_path / "ranges.csv"
    rl = rng.read_text().splitlines()
    rng.write_text("\n".join([rl[0], *reversed(rl[1:])]) + "\n")
    r = read_session(tmp_path)
    np.testing.assert_allclose(r.nav["A"].time_s, s.nav["A"].time_s, atol=1e-9)
    assert np.all(np.diff(r.ranges.frame["time"]) >= 0)
    joined = "\n".join(r.notes)
    assert "nav_A.csv: times not in order (1 step(s) back); rows sorted by time" in joined
    assert "nav_A.csv: 1 duplicated epoch(s) dropped" in joined
    assert "ranges.csv: times not in order; rows sorted by time" in joined


@pytest.mark.parametrize("encoding", ["json", "ros2"])
def test_mcap_round_trip(kit: Any, tmp_path: Path, encoding: str) -> None:
    s = kit.make_session()
    path = write_mcap(s, tmp_path / "s.mcap", encoding=encoding)  # type: ignore[arg-type]
    r = read_session(path)
    kit.assert_same_session(s, r, pos_tol=1e-6 if encoding == "ros2" else 2e-4)
    np.testing.assert_allclose(r.nav["B"].heading_deg, s.nav["B"].heading_deg, atol=1e-9)
    np.testing.assert_allclose(r.nav["B"].vel_enu_mps, s.nav["B"].vel_enu_mps, atol=1e-9)
    if encoding == "json":
        assert list(r.ranges.extra_columns) == ["rssi"]
    # The same file inside a session directory reads the same.
    kit.assert_same_session(s, read_session(tmp_path))


def test_mcap_needs_non_negative_times(kit: Any, tmp_path: Path) -> None:
    s = kit.make_session(time_base="relative")
    nav = {p: dataclasses.replace(t, time_s=t.time_s - 1.0) for p, t in s.nav.items()}
    with pytest.raises(OutputError, match="negative times"):
        write_mcap(dataclasses.replace(s, nav=nav), tmp_path / "x.mcap")
