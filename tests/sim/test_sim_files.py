"""Simulated sessions through the real writers, readers, `coopproc simulate` and `validate`."""

from __future__ import annotations

import dataclasses
import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from mcap.reader import make_reader

from coopproc.cli import main
from coopproc.io import read_session, write_mcap
from coopproc.model import RangeTable
from coopproc.sim import SCENARIOS, simulate, write_simulation
from coopproc.sim.writer import session_as_written


def _files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def test_cli_is_byte_for_byte_deterministic_by_seed(tmp_path: Path) -> None:
    runner = CliRunner()
    args = ["simulate", "--scenario", "paper-experiment", "--duration", "120", "--mcap"]
    for name, seed in (("one", "4"), ("two", "4"), ("three", "5")):
        result = runner.invoke(main, [*args, str(tmp_path / name / "s"), "--seed", seed])
        assert result.exit_code == 0, result.output
    one, two, three = (_files(tmp_path / n / "s") for n in ("one", "two", "three"))
    assert one == two
    assert "mcap/paper-experiment.mcap" in one and "truth/nlos_events.csv" in one
    assert one["ranges.csv"] != three["ranges.csv"]
    command = "coopproc simulate s --scenario paper-experiment --seed 4 --duration 120 --mcap"
    assert command in one["README.md"].decode()
    again = runner.invoke(main, [*args, str(tmp_path / "one" / "s")])
    assert again.exit_code == 1 and "--force" in again.output


def test_round_trip_through_writers_and_readers(tmp_path: Path) -> None:
    sim = simulate("paper-experiment", seed=1, duration_s=300.0)
    write_simulation(sim, tmp_path / "s", mcap=True)
    for source in (tmp_path / "s", tmp_path / "s" / "mcap" / "paper-experiment.mcap"):
        back = read_session(source)
        assert back.platform_ids == ("A", "B", "C")
        assert back.config.time_base == "gps_tow" and back.config.gps_week == 2178
        assert back.config.uwb_sigma_m == 0.15
        for pid in ("A", "B", "C"):
            assert back.platforms[pid].role == sim.session.platforms[pid].role
            assert back.platforms[pid].drift_sigma_mps == sim.session.platforms[pid].drift_sigma_mps
            np.testing.assert_allclose(back.nav[pid].time_s, sim.session.nav[pid].time_s, atol=1e-6)
            np.testing.assert_allclose(back.nav[pid].enu_m, sim.session.nav[pid].enu_m, atol=2e-6)
            ref = sim.session.reference[pid]
            assert ref.quality is not None
            fixed = ref.quality == 1  # the readers keep Q = 1 by default
            np.testing.assert_allclose(back.reference[pid].time_s, ref.time_s[fixed], atol=1e-3)
            np.testing.assert_allclose(back.reference[pid].enu_m, ref.enu_m[fixed], atol=2e-3)
        mine = sim.session.ranges.frame.reset_index(drop=True)
        theirs = back.ranges.frame.reset_index(drop=True)
        assert list(theirs["pair"]) == list(mine["pair"])
        np.testing.assert_allclose(theirs["range"], mine["range"], atol=1e-6)
        np.testing.assert_allclose(theirs["rssi"], mine["rssi"], atol=1e-6)


def test_written_ranges_carry_the_configured_nlos_means(tmp_path: Path) -> None:
    write_simulation(simulate("paper-table1", seed=11), tmp_path / "t")
    ranges = read_session(tmp_path / "t").ranges.frame
    truth = pd.read_csv(tmp_path / "t" / "truth" / "distances.csv")
    events = pd.read_csv(tmp_path / "t" / "truth" / "nlos_events.csv")
    assert list(events.columns)[:5] == ["pair", "start", "end", "nominal_mean", "realized_mean"]
    assert np.allclose(ranges["time"].to_numpy(), truth["time"].to_numpy(), atol=1e-6)
    error = ranges["range"].to_numpy() - truth["distance"].to_numpy()
    for row in events.itertuples():
        inside = ((truth["time"] >= row.start) & (truth["time"] <= row.end)).to_numpy()
        tolerance = 4 * np.hypot(0.08, 0.1) / np.sqrt(inside.sum())
        assert error[inside].mean() == pytest.approx(row.nominal_mean, abs=tolerance)
        assert row.realized_mean == pytest.approx(
            row.nominal_mean, abs=4 * 0.1 / np.sqrt(inside.sum())
        )


_SHORT = {
    "paper-experiment": ["--duration", "120"],
    "paper-table1": [],
    "anchors": ["--duration", "120"],
    "tag-only": ["--duration", "120"],
    "handcart": ["--duration", "60"],
    "land-vehicle": ["--duration", "60"],
    "single-auxiliary": ["--duration", "120", "--set", "second_aux=true"],
    "multi-auxiliary": ["--duration", "120"],
    "large": ["--duration", "300", "--platforms", "4"],
    "dr-faults": ["--duration", "120"],
    "noisy-leader": ["--duration", "120"],
    "body-blocked": ["--duration", "120"],
    "nav-gaps": ["--duration", "180"],
    "quadrotor": ["--duration", "60"],
}


@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_every_scenario_validates_clean(tmp_path: Path, scenario: str) -> None:
    runner = CliRunner()
    out = tmp_path / scenario
    made = runner.invoke(main, ["simulate", str(out), "--scenario", scenario, *_SHORT[scenario]])
    assert made.exit_code == 0, made.output
    checked = runner.invoke(main, ["validate", str(out)])
    assert checked.exit_code == 0, checked.output
    truth = out / "truth"
    moving = [p for p, spec in read_session(out).platforms.items() if spec.role != "anchor"]
    for pid in moving:
        assert (truth / f"traj_{pid}.csv").exists()
    header = (truth / "dr_error.csv").read_text().splitlines()[0]
    assert header == "time,platform,error_east,error_north,error_up,error_h"


def test_new_scenarios_write_their_truth_and_remake_from_the_readme(tmp_path: Path) -> None:
    runner = CliRunner()
    args = ["--scenario", "nav-gaps", "--duration", "180", "--seed", "3", "--set"]
    made = runner.invoke(main, ["simulate", str(tmp_path / "g"), *args, "exact_ranges=true"])
    assert made.exit_code == 0, made.output
    readme = (tmp_path / "g" / "README.md").read_text()
    command = (
        "coopproc simulate g --scenario nav-gaps --seed 3 --duration 180 --set exact_ranges=true"
    )
    assert command in readme and "EXACT" in readme and "| A | nav_gap |" in readme
    again = runner.invoke(
        main, ["simulate", str(tmp_path / "again" / "g"), *args, "exact_ranges=true"]
    )
    assert again.exit_code == 0, again.output
    assert _files(tmp_path / "g") == _files(tmp_path / "again" / "g")
    faults = pd.read_csv(tmp_path / "g" / "truth" / "nav_faults.csv")
    assert list(faults.columns) == ["platform", "fault", "start", "end", "value"]
    params = (tmp_path / "g" / "truth" / "params.toml").read_text()
    assert "exact_ranges = true" in params and "nav_gaps = [" in params
    assert "heading_drift_dpm" not in params  # parameters added later: only when set
    ranges = read_session(tmp_path / "g").ranges.frame
    truth = pd.read_csv(tmp_path / "g" / "truth" / "distances.csv")
    assert np.abs(ranges["range"].to_numpy() - truth["distance"].to_numpy()).max() < 1e-6
    # velocities of the noisy leader go through the nav CSV and come back
    write_simulation(simulate("noisy-leader", seed=1, duration_s=30.0), tmp_path / "n", mcap=True)
    header = (tmp_path / "n" / "nav_B.csv").read_text().splitlines()[0]
    assert "vel_east,vel_north,vel_up" in header
    for source in (tmp_path / "n", tmp_path / "n" / "mcap" / "noisy-leader.mcap"):
        back = read_session(source).nav["B"]
        assert back.vel_enu_mps is not None and np.isfinite(back.vel_enu_mps).all()
    assert not (tmp_path / "n" / "truth" / "nav_faults.csv").exists()


def _mcap_content(data: bytes) -> tuple[tuple[Any, ...], list[tuple[Any, ...]]]:
    """(header, schemas, channels, attachments, metadata) and the messages of an MCAP file.

    Decoded, so independent of how the chunks were compressed: the zstd library's output
    differs between versions for the same input.
    """
    reader = make_reader(io.BytesIO(data))
    header = reader.get_header()
    summary = reader.get_summary()
    assert summary is not None
    schemas = sorted((s.id, s.name, s.encoding, s.data) for s in summary.schemas.values())
    channels = sorted(
        (c.id, c.topic, c.message_encoding, c.schema_id, sorted(c.metadata.items()))
        for c in summary.channels.values()
    )
    messages = [
        (channel.topic, channel.message_encoding, message.sequence, message.log_time,
         message.publish_time, message.data)
        for _, channel, message in reader.iter_messages(log_time_order=False)
    ]  # fmt: skip
    attachments = [
        (a.name, a.media_type, a.log_time, a.create_time, a.data) for a in reader.iter_attachments()
    ]
    metadata = [(m.name, sorted(m.metadata.items())) for m in reader.iter_metadata()]
    return (header.profile, header.library, schemas, channels, attachments, metadata), messages


def _same_json(one: bytes, two: bytes) -> bool:
    """Same keys in the same order, same values; floats equal to 1e-12 relative.

    numpy's sin/cos/arctan2 pick a SIMD kernel by CPU (AVX-512 or AVX2), and the kernels
    can differ in the last bit; the JSON messages carry every digit, so the same simulation
    can differ there by ~1e-14 between machines. Any real change is far larger.
    """
    a, b = json.loads(one), json.loads(two)
    if list(a) != list(b):
        return False
    for key, x in a.items():
        y = b[key]
        if isinstance(x, float) and isinstance(y, float):
            if not math.isclose(x, y, rel_tol=1e-12, abs_tol=1e-12):
                return False
        elif x != y:
            return False
    return True


def _same_mcap(one: bytes, two: bytes) -> bool:
    """Same schemas, channels, attachments, metadata and messages (topic, sequence, log
    and publish time, data: bytes, or JSON values to 1e-12) whatever the compression."""
    (head_a, msgs_a), (head_b, msgs_b) = _mcap_content(one), _mcap_content(two)
    if head_a != head_b or len(msgs_a) != len(msgs_b):
        return False
    for a, b in zip(msgs_a, msgs_b, strict=True):
        if a[:5] != b[:5]:
            return False
        if a[5] != b[5] and not (a[1] == "json" and _same_json(a[5], b[5])):
            return False
    return True


def _same_file(name: str, one: bytes, two: bytes) -> bool:
    return _same_mcap(one, two) if name.endswith(".mcap") else one == two


def test_mcap_comparison_ignores_compression_sees_a_changed_range(tmp_path: Path) -> None:
    sim = simulate("paper-experiment", seed=0, duration_s=20.0)
    write_simulation(sim, tmp_path / "a", mcap=True)
    frame = sim.session.ranges.frame.copy()
    frame.loc[frame.index[-1], "range"] += 0.001
    other = dataclasses.replace(
        sim,
        session=dataclasses.replace(sim.session, ranges=RangeTable(frame, source="simulated")),
    )
    write_simulation(other, tmp_path / "b", mcap=True)
    name = "mcap/paper-experiment.mcap"
    one, two = (_files(tmp_path / d)[name] for d in ("a", "b"))
    as_files, llh = session_as_written(sim.session, tmp_path / "scratch")
    lz4_path = write_mcap(as_files, tmp_path / "lz4.mcap", compression="lz4", reference_llh=llh)
    lz4 = lz4_path.read_bytes()
    assert lz4 != one and _same_file(name, one, lz4)
    assert not _same_file(name, one, two)


def test_shipped_sample_logs_are_what_the_simulator_makes(tmp_path: Path) -> None:
    # MCAP files are compared by their decoded content (zstd output depends on the
    # library version), every other file byte for byte
    shipped = Path(__file__).resolve().parents[2] / "sample_logs"
    if not shipped.is_dir():
        pytest.skip("no sample_logs/ in this checkout")
    made = tmp_path / "sample_logs"
    write_simulation(simulate("paper-experiment", seed=0), made, mcap=True)
    expected, actual = _files(made), _files(shipped)
    assert sorted(actual) == sorted(expected)
    stale = [name for name in expected if not _same_file(name, expected[name], actual[name])]
    assert not stale, (
        f"sample_logs/ is stale ({stale}); regenerate: coopproc simulate sample_logs "
        "--scenario paper-experiment --seed 0 --mcap --force"
    )


def test_anchors_through_ros2_mcap(tmp_path: Path) -> None:
    sim = simulate("anchors", seed=2, duration_s=120.0)
    write_simulation(sim, tmp_path / "a", mcap=True, mcap_encoding="ros2")
    back = read_session(tmp_path / "a" / "mcap" / "anchors.mcap")
    anchors = {p: spec for p, spec in back.platforms.items() if spec.role == "anchor"}
    assert sorted(anchors) == [f"AN{k}" for k in range(1, 7)]
    for pid, spec in anchors.items():
        assert spec.position_enu_m is not None
        np.testing.assert_allclose(
            spec.position_enu_m, sim.session.platforms[pid].position_enu_m, atol=1e-6
        )
    np.testing.assert_allclose(
        back.ranges.frame["range"], sim.session.ranges.frame["range"], atol=1e-6
    )
    np.testing.assert_allclose(back.nav["tag"].enu_m, sim.session.nav["tag"].enu_m, atol=1e-5)
