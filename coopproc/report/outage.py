"""Drift against outage length (paper 003 section 3.4, Fig. 9-10): ``outages.csv`` and the
``coopproc report --outages`` table.

For each outage window (``[run] outages``, ``coopproc run --outage``: the ranges inside
were withheld from every method) and each method and platform of ``positions.csv`` (its
own navigation ``nav`` included, the ``reference`` rows left out), from the horizontal
errors ``error_h`` of the rows inside the window, both ends included:

| column | meaning |
|---|---|
| ``window`` | 1, 2, ... in time order |
| ``start``, ``end`` | the window, session time base, s |
| ``length_s`` | end - start, s |
| ``platform``, ``method`` | as in positions.csv |
| ``epochs`` | rows with an error inside the window (0: the method has no position there) |
| ``error_start`` | error at the first of them, m |
| ``error_end`` | error at the last of them: the drift at the end of the outage, m |
| ``error_max`` | largest error inside, m |
| ``error_rms`` | RMS error inside, m |

The drift curves (error against time since the outage started) are :func:`drift_curves`.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import pandas as pd

from coopproc.report.latex_layout import Grid, LatexWidth, number_cell, render_grid, text_cell
from coopproc.report.table_specs import method_label

__all__ = ["OUTAGE_COLUMNS", "drift_curves", "format_outages", "outage_table"]

OUTAGE_COLUMNS: tuple[str, ...] = (
    "window",
    "start",
    "end",
    "length_s",
    "platform",
    "method",
    "epochs",
    "error_start",
    "error_end",
    "error_max",
    "error_rms",
)

#: Rows of positions.csv that are not a method's solution.
_NOT_METHODS = ("reference",)


def _methods(rows: pd.DataFrame) -> list[str]:
    """The methods of ``rows``, ``nav`` first, the others in order of appearance."""
    names = [str(m) for m in dict.fromkeys(rows["method"]) if m not in _NOT_METHODS]
    return sorted(names, key=lambda m: m != "nav")


def outage_table(positions: pd.DataFrame, windows: Sequence[tuple[float, float]]) -> pd.DataFrame:
    """outages.csv from positions.csv and the windows (session time base); see the module
    docstring. Platforms without any horizontal error (no reference) are left out."""
    records = []
    scored = positions[np.isfinite(positions["error_h"].to_numpy(dtype=np.float64))]
    platforms = sorted(str(p) for p in scored["platform"].unique())
    for k, (start, end) in enumerate(windows, start=1):
        for platform in platforms:
            rows = positions[positions["platform"] == platform]
            for method in _methods(rows):
                own = rows[rows["method"] == method].sort_values("time", kind="stable")
                t = own["time"].to_numpy(dtype=np.float64)
                err = own["error_h"].to_numpy(dtype=np.float64)
                inside = (t >= start - 1e-9) & (t <= end + 1e-9) & np.isfinite(err)
                e = err[inside]
                records.append(
                    {
                        "window": k,
                        "start": start,
                        "end": end,
                        "length_s": end - start,
                        "platform": platform,
                        "method": method,
                        "epochs": int(e.size),
                        "error_start": e[0] if e.size else np.nan,
                        "error_end": e[-1] if e.size else np.nan,
                        "error_max": e.max() if e.size else np.nan,
                        "error_rms": float(np.sqrt(np.mean(e**2))) if e.size else np.nan,
                    }
                )
    return pd.DataFrame(records, columns=list(OUTAGE_COLUMNS))


def drift_curves(
    positions: pd.DataFrame, outages: pd.DataFrame, platform: str
) -> dict[str, list[tuple[int, np.ndarray, np.ndarray]]]:
    """Per method, one (window number, time since the outage start, horizontal error)
    curve per window of ``outages`` (outages.csv) for ``platform`` that it has rows in;
    methods without rows inside are left out."""
    out: dict[str, list[tuple[int, np.ndarray, np.ndarray]]] = {}
    rows = positions[positions["platform"] == platform]
    windows = outages[outages["platform"] == platform].drop_duplicates("window")
    for method in _methods(rows):
        own = rows[rows["method"] == method].sort_values("time", kind="stable")
        t = own["time"].to_numpy(dtype=np.float64)
        err = own["error_h"].to_numpy(dtype=np.float64)
        for number, start, end in zip(
            windows["window"], windows["start"], windows["end"], strict=True
        ):
            inside = (t >= start - 1e-9) & (t <= end + 1e-9) & np.isfinite(err)
            if inside.any():
                curve = (int(number), t[inside] - start, err[inside])
                out.setdefault(method, []).append(curve)
    return out


#: (column, header, decimals; -1: text) of the printed table.
_COLS: tuple[tuple[str, str, int], ...] = (
    ("window", "Window", 0),
    ("span", "Span (s)", -1),
    ("length_s", "Length (s)", 1),
    ("platform", "Platform", -1),
    ("method", "Method", -1),
    ("epochs", "Epochs", 0),
    ("error_start", "Start (m)", 3),
    ("error_end", "End (m)", 3),
    ("error_max", "Max (m)", 3),
    ("error_rms", "RMS (m)", 3),
)
_TITLE = "Horizontal position error inside each UWB outage (paper 003 sec. 3.4)"


def _rows(
    outages: pd.DataFrame, origin_s: float, order: Sequence[str], labels: bool
) -> list[dict[str, object]]:
    """The table's rows by window, platform and method in ``order`` (the other tables'
    paper order: own nav, Observed, RN-Based, DI-Based, then the run's others), each
    method by its display name (``labels``; the csv keeps the ids)."""
    rank = {m: i for i, m in enumerate(order)}
    records = sorted(
        outages.to_dict("records"),
        key=lambda r: (
            int(r["window"]),
            str(r["platform"]),
            rank.get(str(r["method"]), len(rank)),
            str(r["method"]),
        ),
    )
    rows = []
    for rec in records:
        span = f"{rec['start'] - origin_s:.1f}-{rec['end'] - origin_s:.1f}"
        method = method_label(str(rec["method"])) if labels else rec["method"]
        rows.append({**{str(k): v for k, v in rec.items()}, "span": span, "method": method})
    return rows


def _cell(value: object, decimals: int, *, plain: bool = False) -> str:
    if decimals < 0:
        return str(value)
    v = float(value)  # type: ignore[arg-type]
    if not math.isfinite(v):
        return "" if plain else "-"
    return f"{v:.{decimals}f}"


def format_outages(
    outages: pd.DataFrame,
    fmt: Literal["terminal", "csv", "md", "latex"] = "terminal",
    *,
    origin_s: float = 0.0,
    latex_width: LatexWidth = "single",
    order: Sequence[str] = ("nav", "observed", "rn", "di"),
) -> str:
    """The outages table in ``fmt``; spans in seconds from ``origin_s`` (the run's time
    origin, as the figures count); methods in ``order`` (others after, by name)."""
    rows = _rows(outages, origin_s, order, labels=fmt != "csv")
    header = [h for _, h, _ in _COLS]
    if fmt == "csv":
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow([c for c, _, _ in _COLS])
        for r in rows:
            writer.writerow([_cell(r[c], d, plain=True) for c, _, d in _COLS])
        return f"# {_TITLE}\n" + buf.getvalue()
    body = [[_cell(r[c], d) for c, _, d in _COLS] for r in rows]
    if fmt == "md":
        out = [f"**{_TITLE}**", "", "| " + " | ".join(header) + " |"]
        out.append("|" + "|".join("---" if d < 0 else "---:" for _, _, d in _COLS) + "|")
        out += ["| " + " | ".join(cells) + " |" for cells in body]
        return "\n".join(out) + "\n"
    if fmt == "latex":
        tops = tuple(text_cell(h.split(" (")[0]) for h in header)
        units = tuple(text_cell(f"({h.split(' (')[1]}" if " (" in h else "") for h in header)
        lines = tuple(
            tuple(
                text_cell(c) if d < 0 else number_cell(c)
                for c, (_, _, d) in zip(cells, _COLS, strict=True)
            )
            for cells in body
        )
        grid = Grid(
            key="outages",
            title=_TITLE,
            caption=f"{_TITLE}.",
            align="".join("l" if d < 0 else "r" for _, _, d in _COLS),
            tops=tops,
            units=units,
            lines=lines,
            stub=1,
        )
        return render_grid(grid, latex_width)
    widths = [max(len(row[i]) for row in [header, *body]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        return "  ".join(
            c.ljust(w) if d < 0 else c.rjust(w)
            for c, w, (_, _, d) in zip(cells, widths, _COLS, strict=True)
        ).rstrip()

    rule = "-" * len(line(header))
    if not body:
        return f"{_TITLE}\n(no outage windows in this run: coopproc run --outage T0:T1)\n"
    return "\n".join([_TITLE, rule, line(header), rule, *map(line, body), rule]) + "\n"
