"""NavSatFix status <-> RTKLIB Q: the reading of every status value, coopproc's exact-Q
encoding, and its round trip through a ROS 2 MCAP file."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap_ros2.writer import Writer as Ros2Writer

from coopproc.io import read_session, write_mcap
from coopproc.io.mcap_read import decode_mcap
from coopproc.io.mcap_scan import scan_mcap
from coopproc.io.navsat_status import navsat_quality, navsat_status
from coopproc.io.ros2_msgdefs import NAVSATFIX, UWB_RANGE_MAPPING
from coopproc.io.session_toml import McapMapping


def _read(status: list[int], service: list[int] | None = None) -> Any:
    service = [1] * len(status) if service is None else service
    return navsat_quality(np.array(status), np.array(service), None, "f.mcap /A/fix")


@pytest.mark.parametrize(
    ("status", "quality", "kept"),
    [(2, 1, True), (1, 3, True), (0, 5, True), (-1, 0, False), (-2, 0, False), (-7, 0, False)],
)
def test_each_status_of_a_foreign_navsatfix(status: int, quality: int, kept: bool) -> None:
    q = _read([status, 0])
    assert q.quality.tolist() == [quality, 5]
    assert q.keep.tolist() == [kept, True]
    if not kept:
        assert q.notes == [
            f"f.mcap /A/fix: 1 of 2 NavSatFix messages without a fix "
            f"({ {-1: 'NO_FIX', -2: 'UNKNOWN'}.get(status, 'status') } ({status})) left out"
        ]
    elif status == 2:
        assert len(q.notes) == 1
        assert "cannot tell RTK fixed from float: 1 GBAS_FIX (2) epochs read as Q=1" in q.notes[0]
    else:
        assert q.notes == []


def test_one_fixed_or_float_note_per_channel_with_the_median_sigma() -> None:
    sigma_h = np.array([0.01, 0.02, 0.5, 3.0])
    q = navsat_quality(np.array([2, 2, 2, 0]), np.ones(4, np.int64), sigma_h, "f /A/fix")
    (note,) = q.notes
    assert "3 GBAS_FIX (2) epochs read as Q=1 (fixed) (median horizontal sigma 0.020 m" in note


@pytest.mark.parametrize(
    ("q", "status"), [(1, 2), (2, 2), (3, 1), (4, 2), (5, 0), (6, 0), (0, -1), (None, 2)]
)
def test_coopproc_encoding_keeps_the_status_standard_and_q_exact(
    q: int | None, status: int
) -> None:
    s, service = navsat_status(q)
    assert s == status
    assert service & 0xFF == 1  # SERVICE_GPS, the standard bits untouched
    back = _read([s], [service])
    if status < 0:
        assert not back.keep[0]
    else:
        assert back.quality.tolist() == [1 if q is None else q]
        assert back.notes == []  # an exact Q: no fixed-or-float doubt


def test_a_high_byte_that_disagrees_with_the_status_is_not_taken_as_q() -> None:
    # Q 5 (single) with status 2 cannot be coopproc's: read as a foreign GBAS_FIX
    q = _read([2, 0], [1 | 5 << 8, 1 | 2 << 8])
    assert q.quality.tolist() == [1, 5]
    assert len(q.notes) == 1


def test_every_q_round_trips_through_a_ros2_mcap(tmp_path: Path, kit: Any) -> None:
    s = kit.make_session()
    n = len(s.reference["A"])
    quality = np.resize(np.array([1, 2, 3, 4, 5, 6, 0]), n).astype(np.int64)
    ref = dict(s.reference)
    ref["A"] = dataclasses.replace(ref["A"], quality=quality)
    ref["B"] = dataclasses.replace(ref["B"], quality=None)
    s = dataclasses.replace(s, reference=ref)
    path = write_mcap(s, tmp_path / "q.mcap", encoding="ros2")
    content = decode_mcap(scan_mcap(path), McapMapping(**UWB_RANGE_MAPPING))
    a = content.reference["A"]
    assert a.quality is not None and a.quality.tolist() == quality[quality > 0].tolist()
    np.testing.assert_array_equal(a.time_s, s.reference["A"].time_s[quality > 0])
    assert content.reference["B"].quality.tolist() == [1] * n  # type: ignore[union-attr]
    assert a.notes == [f"{path} /A/reference: 7 of {n} NavSatFix messages without a fix "
                       "(NO_FIX (-1)) left out"]  # fmt: skip
    # The default Q filter ([1]) sees the float epochs as float: fixed ones kept only
    assert len(read_session(path).reference["A"]) == int(np.sum(quality == 1))


def _fix(t_ns: int, status: int, lat: float) -> dict[str, Any]:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    return {
        "header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": "gps"},
        "status": {"status": status, "service": 1},
        "latitude": lat,
        "longitude": 113.659 if status >= 0 else float("nan"),
        "altitude": 110.0,
        "position_covariance": [0.0] * 9,
        "position_covariance_type": 0,
    }


def test_a_foreign_recording_with_no_fix_messages_reads_with_notes(tmp_path: Path) -> None:
    # A driver's NO_FIX messages hold NaN positions: left out with a note, not an error
    path = tmp_path / "rec.mcap"
    t0 = 432_000 * 1_000_000_000
    status = [-1 if i in (4, 5) else (0 if i == 9 else 2) for i in range(20)]
    with open(path, "wb") as fh:
        w = Ros2Writer(fh)
        fix = w.register_msgdef("sensor_msgs/msg/NavSatFix", NAVSATFIX)
        for i, st in enumerate(status):
            t = t0 + i * 100_000_000
            lat = float("nan") if st < 0 else 34.798 + 1e-6 * i
            w.write_message("/A/reference", fix, _fix(t, st, lat), t, t, i)
        w.finish()
    raw = decode_mcap(scan_mcap(path), McapMapping()).reference["A"]
    assert raw.quality is not None
    assert raw.quality.tolist() == [5 if st == 0 else 1 for st in status if st >= 0]
    np.testing.assert_array_equal(
        raw.time_s * 10, [4320000 + i for i in range(20) if i not in (4, 5)]
    )
    assert raw.notes == [
        f"{path} /A/reference: 2 of 20 NavSatFix messages without a fix (NO_FIX (-1)) left out",
        f"{path} /A/reference: NavSatFix status cannot tell RTK fixed from float: 17 GBAS_FIX "
        "(2) epochs read as Q=1 (fixed); if the receiver reports float solutions as GBAS_FIX "
        "too, give the reference as RTKLIB .pos or as ref_<ID>.csv with a quality column",
    ]
