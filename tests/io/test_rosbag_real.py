"""The real TIERS bags (../shared/data/bags/tiers_case4): ROS 1 = ROS 2, and real/tiers.

real/tiers (the coopproc session converted from ros2/test3) says in its README which
corrections it applied; reading test3 with a [topics] mapping reproduces it exactly:
n_8 dropped (22166 ranges left), A->B / B->A copies dropped (a range equal to its pair's
previous one less than 5 ms before: 11077 left), then the ranges of the two parked
robots' pair tb1-tb2 and those outside the navigation span dropped: the 10599 rows of
real/tiers/ranges.csv, same direction, same header-stamp time, range_raw_ds = the bag's
range.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io.rosbag_read import BagContent, read_bag
from coopproc.io.rosbag_scan import inventory, open_bag
from coopproc.io.rosbag_suggest import suggest
from coopproc.io.session_toml import parse_session_toml
from coopproc.io.topics_toml import parse_topics

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
BAGS = DATA / "bags" / "tiers_case4"
REAL = DATA / "real" / "tiers"
pytestmark = pytest.mark.skipif(
    not (BAGS / "ros2" / "test3").exists() or not REAL.exists(),
    reason="../shared/data (TIERS bags and real/tiers) not present",
)

RENAME = "\n".join(f'n_{k} = "tb{k}"\nturtlebot{k} = "tb{k}"' for k in range(1, 8))
TOML = f"""
[topics]
reference = "/vrpn_client_node/{{id}}/pose"
ranges = "/uwb/tof/{{from}}/{{to}}/distance"
drop = ["n_8"]
duplicates_s = 0.005

[topics.rename]
{RENAME}
"""


def _session(tmp: Path, bag: Path, toml: str) -> Path:
    root = tmp / bag.name.removesuffix(".bag")
    root.mkdir()
    if bag.is_dir():
        shutil.copytree(bag, root / bag.name)
    else:
        shutil.copy(bag, root / bag.name)
    (root / "session.toml").write_text(toml)
    return root


@pytest.fixture(scope="module")
def test1() -> dict[str, BagContent]:
    mapping = parse_topics(
        {"reference": "/vrpn_client_node/{id}/pose", "ranges": "/uwb/tof/{from}/{to}/distance"}
    )
    return {
        "ros2": read_bag(BAGS / "ros2" / "test1", mapping),
        "ros1": read_bag(BAGS / "ros1" / "test1.bag", mapping),
    }


def test_ros1_and_ros2_forms_of_test1_are_the_same_session(test1: dict[str, BagContent]) -> None:
    a, b = test1["ros2"], test1["ros1"]
    assert a.ranges is not None and b.ranges is not None
    fa, fb = a.ranges.table.frame, b.ranges.table.frame
    assert len(fa) == 16011 and fa.equals(fb)  # every range, time and direction, to the bit
    cm = fa["range"].to_numpy() * 100  # UWB ranges in whole centimetres (float32)
    assert (
        np.abs(cm - np.round(cm)).max() < 1e-4 and 0.2 < fa["range"].min() < fa["range"].max() < 10
    )
    assert sorted(a.reference) == [f"turtlebot{k}" for k in range(1, 8)]
    for pid, ra in a.reference.items():
        rb = b.reference[pid]
        assert ra.time_s.size in (1027, 1028)
        np.testing.assert_array_equal(ra.time_s, rb.time_s)
        np.testing.assert_array_equal(ra.position, rb.position)
    # header stamps (March 2023), not the log times (May 2023)
    assert 1678965826.0 < a.reference["turtlebot3"].time_s[0] < 1678965827.0


#: One double at the bags' Unix times (1.68e9 s).
ULP = float(np.spacing(1.7e9))


@pytest.fixture(scope="module")
def test3() -> BagContent:
    return read_bag(BAGS / "ros2" / "test3", parse_session_toml(TOML).topics)


def test_test3_reproduces_the_raw_ranges_of_real_tiers(test3: BagContent) -> None:
    assert test3.ranges is not None
    f = test3.ranges.table.frame
    assert len(f) == 11077  # README: 22166 -> 11077 once the copies are dropped
    notes = "\n".join(test3.notes)
    assert "7400 range(s) of dropped names left out" in notes  # n_8: 29566 -> 22166
    assert "11089 range(s) equal to their pair's previous range" in notes
    nav = pd.read_csv(REAL / "nav_tb3.csv")["time"]
    kept = f[(f["pair"] != "tb1-tb2") & (f["time"] >= nav.min()) & (f["time"] <= nav.max())]
    real = pd.read_csv(REAL / "ranges.csv")
    assert len(kept) == len(real) == 10599
    a = kept.sort_values(["from", "to", "time"]).reset_index(drop=True)
    b = real.sort_values(["from", "to", "time"]).reset_index(drop=True)
    assert (a["from"] == b["from"]).all() and (a["to"] == b["to"]).all()
    # 6 decimals in the CSV, made from sec + nsec * 1e-9, which can be one double (2.4e-7
    # s at 1.7e9 s) off the stamp that (sec * 1e9 + nsec) / 1e9 reads now
    assert np.abs(a["time"] - b["time"]).max() < 5e-7 + ULP
    assert np.abs(a["range"] - b["range_raw_ds"]).max() < 5e-7  # float32 of cm values
    np.testing.assert_allclose(b["range"], b["range_raw_ds"] - b["bias_test1_ds"], atol=1e-4)


def test_test3_reference_is_the_mocap_of_real_tiers(test3: BagContent) -> None:
    for k in range(3, 8):
        ref = test3.reference[f"tb{k}"]
        real = pd.read_csv(REAL / f"ref_tb{k}.csv")
        assert ref.time_s.size == len(real)
        assert np.abs(ref.time_s - real["time"].to_numpy()).max() < 5e-7 + ULP  # as above
        assert ref.form == "enu"  # pose position = east, north, up
        assert np.abs(ref.position - real[["east", "north", "up"]].to_numpy()).max() < 5.1e-5


def test_info_suggests_the_tiers_mapping() -> None:
    bag = BAGS / "ros2" / "test3"
    with open_bag(bag) as reader:
        inv = inventory(reader, bag)
    assert len(inv.topics) == 63 and sum(t.count for t in inv.topics) == 42939
    text = suggest(inv.types, inv.fields).toml
    assert 'reference = "/vrpn_client_node/{id}/pose"' in text
    assert 'ranges = "/uwb/tof/{from}/{to}/distance"' in text
    assert 'drop = ["n_8"]' in text and 'n_1 = "turtlebot1"' in text
    assert '# nav = "/vrpn_client_node/{id}/pose"' in text  # no odometry in these bags
    result = CliRunner().invoke(main, ["info", str(BAGS / "ros1" / "test1.bag")])
    assert result.exit_code == 0, result.output
    assert "(ROS 1, 63 topics, 23206 messages" in result.output
    assert "not a complete session yet: " in result.output  # no navigation


@pytest.mark.slow
def test_run_on_the_test3_bag_end_to_end(tmp_path: Path) -> None:
    """Three robots (the others dropped), mocap pose mapped as reference and as nav."""
    toml = TOML.replace('drop = ["n_8"]', 'drop = ["n_8", "tb1", "tb2", "tb6", "tb7"]')
    toml = toml.replace("[topics]\n", '[topics]\nnav = "/vrpn_client_node/{id}/pose"\n')
    root = _session(tmp_path, BAGS / "ros2" / "test3", toml)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", str(root), "-o", str(out), "--no-figures", "-q"])
    assert result.exit_code == 0, result.output
    ranges = pd.read_csv(out / "ranges.csv")
    assert sorted(set(ranges["pair"])) == ["tb3-tb4", "tb3-tb5", "tb4-tb5"]
    # The reference distance is the real/tiers mocap's at the same times.
    refs = {k: pd.read_csv(REAL / f"ref_{k}.csv") for k in ("tb3", "tb4", "tb5")}
    for pair, sub in ranges.groupby("pair"):
        a, b = (refs[p] for p in pair.split("-"))
        pa = np.column_stack(
            [np.interp(sub["time"], a["time"], a[c]) for c in ("east", "north", "up")]
        )
        pb = np.column_stack(
            [np.interp(sub["time"], b["time"], b[c]) for c in ("east", "north", "up")]
        )
        np.testing.assert_allclose(sub["reference"], np.linalg.norm(pa - pb, axis=1), atol=2e-4)
    positions = pd.read_csv(out / "positions.csv")
    nav = positions[positions["method"] == "nav"]
    assert nav["error_h"].abs().max() < 1e-9  # nav and reference are the same mocap
    assert (out / "run.json").read_text().count("test3_0.db3") >= 1
