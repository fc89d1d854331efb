"""``dr_states``: the fusion's estimate of each follower's dead-reckoning errors over time
(``dr_states.csv``): per follower a panel of its heading error (deg) and one of its
odometer scale error (%), one colour per fusion method, the 1-sigma band shaded; a grey
dotted line where the observed fusion found a jump of the follower's dead reckoning
(run.json ``calibration.fusion.observed.dr_jumps``, a wheel slip, as the terminal reports
them: docs/methods-fusion.md#dr-jumps).

A figure of :mod:`coopproc.report.figures` (registered there); drawn only for a run whose
fusion carried DR states (``[fusion] state = "dr"``, the default, and a follower).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.report.pages import FigureOptions
from coopproc.report.panels import Panels, legend, stack_layout, time_label
from coopproc.report.run_tables import RunTables
from coopproc.report.style import method_style

__all__ = ["DR_FIGURE_NAMES", "dr_states_panels"]

#: Drawn only for a run with DR states; not among the figures every run draws.
DR_FIGURE_NAMES: tuple[str, ...] = ("dr_states",)

#: (column, its 1-sigma column, axis label, factor to the plotted unit)
_QUANTITIES = (
    ("heading_error", "sigma_heading_error", "Heading error (deg)", 1.0),
    ("scale_error", "sigma_scale_error", "Scale error (%)", 100.0),
)


def dr_states_panels(run: RunTables, opts: FigureOptions, _groups: Any = None) -> Panels | None:
    """The panels of ``dr_states`` (None without dr_states.csv rows)."""
    frame = run.dr_states
    if frame is None or not len(frame):
        return None
    platforms = sorted(str(p) for p in frame["platform"].unique() if opts.keep_platform(str(p)))
    if not platforms:
        return None
    rows: dict[str, dict[str, pd.DataFrame]] = {
        p: {str(m): part for m, part in frame[frame["platform"] == p].groupby("method", sort=True)}
        for p in platforms
    }
    keys = [f"{p}:{q[0]}" for p in platforms for q in _QUANTITIES]
    names = {"heading_error": "DR heading error (clockwise)", "scale_error": "odometer scale error"}
    titles = [f"Platform {p}: {names[q[0]]}" for p in platforms for q in _QUANTITIES]
    t0 = run.time_origin_s
    jumps = _jump_times(run.info)

    def draw(ax: Axes, i: int) -> None:
        platform = platforms[i // len(_QUANTITIES)]
        column, sigma, label, factor = _QUANTITIES[i % len(_QUANTITIES)]
        for method, part in rows[platform].items():
            t = part["time"].to_numpy(np.float64) - t0
            value = part[column].to_numpy(np.float64) * factor
            band = part[sigma].to_numpy(np.float64) * factor
            style = method_style(method).kwargs()
            (line,) = ax.plot(t, value, **style)
            ax.fill_between(t, value - band, value + band, color=line.get_color(), alpha=0.15)
        for j, at in enumerate(jumps.get(platform, [])):
            ax.axvline(
                at - t0, color="0.35", linestyle=":", linewidth=1.0,
                label="DR jump found (observed)" if j == 0 else None,
            )  # fmt: skip
        ax.axhline(0.0, color="0.6", linewidth=0.6)
        ax.set_ylabel(label)

    def finish(fig: Figure, axes: list[Axes], drawn: list[Any]) -> None:
        time_label(axes, t0)
        legend(fig, axes)

    return Panels(keys, titles, stack_layout(opts.style), draw, finish, "panels")


def _jump_times(info: Any) -> dict[str, list[float]]:
    """platform -> the times of the jumps the observed fusion found (run.json)."""
    facts = (info or {}).get("calibration", {}).get("fusion", {}).get("observed", {})
    out: dict[str, list[float]] = {}
    for jump in facts.get("dr_jumps", []) if isinstance(facts, dict) else []:
        out.setdefault(str(jump["platform"]), []).append(float(jump["time"]))
    return out
