"""The .pos writer's header times are rounded to the millisecond like its rows, not cut
(issue 32.8: 1317081600.013 s, a float 1317081600.0129998, was headed .012)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coopproc.io.rtklib_pos import write_pos


def test_header_times_are_rounded_as_the_rows(tmp_path: Path) -> None:
    gpst = np.array([1317081600.013, 1317081659.9996])
    llh = np.array([[34.8, 113.6, 110.0], [34.8, 113.6, 110.0]])
    path = write_pos(tmp_path / "a.pos", gpst, llh, time_format="week_tow", time_decimals=6)
    lines = path.read_text().splitlines()
    header = {k.strip("% ").strip(): v.strip() for k, v in (h.split(":", 1) for h in lines[1:3])}
    rows = [line.split()[:2] for line in lines if not line.startswith("%")]
    assert rows == [["2177", "432000.013000"], ["2177", "432059.999600"]]  # week, tow
    assert header["obs start"] == "2021/10/01 00:00:00.013 GPST"  # was .012
    assert header["obs end"] == "2021/10/01 00:01:00.000 GPST"  # was 00:00:59.999
