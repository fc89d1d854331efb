"""Helpers of the issue 14 CSV-form tests: rewrite a session's CSV files as people export them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.model import Session

REPO = Path(__file__).resolve().parents[2]
TUC = REPO.parent / "shared" / "data" / "real" / "tuc"


def rewrite(
    path: Path,
    *,
    sep: str = ",",
    decimal_comma: bool = False,
    encoding: str = "utf-8",
    comment: str = "",
    header: dict[str, str] | None = None,
    scale: dict[str, int] | None = None,
    dst: Path | None = None,
) -> Path:
    """``path`` rewritten: delimiter, decimal commas, encoding, a comment, column names,
    columns scaled by a power of ten (exactly: the decimal point moves in the text)."""
    lines = path.read_text().splitlines()
    names = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:]]
    for column, digits in (scale or {}).items():
        k = names.index(column)
        for row in rows:
            if row[k]:
                number = float(row[k]) * 10**digits
                row[k] = f"{number:.{max(0, 6 - digits)}f}"
    names = [(header or {}).get(n, n) for n in names]
    text = [comment] if comment else []
    text.append(sep.join(names))
    for row in rows:
        cells = [c.replace(".", ",") for c in row] if decimal_comma else row
        text.append(sep.join(cells))
    target = dst or path
    if target != path:
        path.unlink()
    target.write_bytes(("\r\n".join(text) + "\r\n").encode(encoding))
    return target


def add_toml(root: Path, text: str) -> None:
    toml = root / "session.toml"
    toml.write_text(toml.read_text() + "\n" + text)


def assert_same(a: Session, b: Session, *, exact: bool = True) -> None:
    """Same platforms, trajectories and ranges (bit for bit unless ``exact`` is False)."""
    assert dict(a.platforms) == dict(b.platforms)
    assert a.origin_llh == b.origin_llh and a.config.time_base == b.config.time_base
    for ga, gb in ((a.nav, b.nav), (a.reference, b.reference)):
        assert sorted(ga) == sorted(gb)
        for pid in ga:
            for name in ("time_s", "enu_m", "sigma_enu_m", "vel_enu_mps", "heading_deg"):
                x, y = getattr(ga[pid], name), getattr(gb[pid], name)
                assert (x is None) == (y is None), name
                if x is not None and exact:
                    assert np.array_equal(x, y), (pid, name)
                elif x is not None:
                    np.testing.assert_allclose(x, y, rtol=1e-14, atol=1e-12, err_msg=name)
    pd.testing.assert_frame_equal(a.ranges.frame, b.ranges.frame, check_exact=exact)


def notes(session: Session) -> str:
    return "\n".join(session.notes)
