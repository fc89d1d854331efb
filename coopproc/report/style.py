"""The one place that fixes how each method and series looks in every figure.

Colours follow paper 000 where its captions say (fig. 11/12: observed blue solid, RN-Based
green dashed, DI-Based orange dash-dotted; fig. 8: cooperative positioning blue dashed,
dead reckoning orange solid, smoothed green dash-dotted). ``RC`` is applied with
``matplotlib.rc_context`` around figure making only; nothing here changes global state.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Any

__all__ = [
    "COLUMN_WIDTH_IN",
    "DI_STYLES",
    "EXTRA_COLORS",
    "EXTRA_DASHES",
    "MAX_LINE_POINTS",
    "MAX_PANELS",
    "METHOD_STYLES",
    "NLOS_SPAN",
    "PANEL_HEIGHT_IN",
    "RC",
    "WIDE_WIDTH_IN",
    "LineStyle",
    "method_style",
]

#: One journal column (MDPI Sensors, IEEE: about 3.5 in) and the full text width.
COLUMN_WIDTH_IN = 3.5
WIDE_WIDTH_IN = 7.0
#: Height of one panel of a stacked figure.
PANEL_HEIGHT_IN = 1.45
#: Most panels on one page of a figure; more go on further pages (``name_2.png``...).
#: ``coopproc run`` / ``coopproc report --plots`` take ``--max-panels`` to change it.
MAX_PANELS = 24
#: Most points drawn per line and panel: longer series are drawn from their min/max
#: envelope (:mod:`coopproc.report.decimate`); statistics always use every sample.
MAX_LINE_POINTS = 5000


@dataclass(frozen=True)
class LineStyle:
    """Label, colour, line style and width of one series."""

    label: str
    color: str
    #: A matplotlib line style: name or (offset, dash sequence).
    linestyle: Any = "-"
    linewidth: float = 0.9

    def kwargs(self, points: int = 0) -> dict[str, Any]:
        """Keyword arguments for ``Axes.plot``; lines of more than 300 points are thinner."""
        return {
            "label": self.label,
            "color": self.color,
            "linestyle": self.linestyle,
            "linewidth": self.linewidth * (0.65 if points > 300 else 1.0),
        }


METHOD_STYLES: dict[str, LineStyle] = {
    "observed": LineStyle("Observed", "#1f77b4", "-", 0.8),
    "rn": LineStyle("RN-Based", "#2ca02c", "--"),
    "di": LineStyle("DI-Based", "#ff7f0e", "-."),
    "nav": LineStyle("Own nav", "#7f7f7f", ":"),
    "reference": LineStyle("Reference", "#000000", "-", 1.2),
}

#: In drawing order: the noisiest first, so the smoother series stay visible on top.
DI_STYLES: dict[str, LineStyle] = {
    "di_cp": LineStyle("Coop. positioning", "#1f77b4", "--"),
    "di_dr": LineStyle("Dead reckoning", "#ff7f0e", "-"),
    "di_smoothed": LineStyle("Smoothed DI", "#2ca02c", "-."),
}

#: Shading of detected NLOS spans.
NLOS_SPAN: dict[str, Any] = {"color": "#d62728", "alpha": 0.12, "linewidth": 0}

#: Colours and dash patterns of methods beyond the known ones (a chain may add any).
EXTRA_COLORS: tuple[str, ...] = ("#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#393b79")
EXTRA_DASHES: tuple[Any, ...] = ((0, (3, 1, 1, 1)), (0, (5, 1.5)), (0, (1, 1)))


def method_style(method: str) -> LineStyle:
    """The style of a method. A method beyond the known ones is labelled by its name and
    gets a colour and dash pattern from :data:`EXTRA_COLORS` / :data:`EXTRA_DASHES` chosen
    by a checksum of its name: the same in every figure and every run."""
    if method in METHOD_STYLES:
        return METHOD_STYLES[method]
    code = zlib.crc32(method.encode("utf-8"))
    color = EXTRA_COLORS[code % len(EXTRA_COLORS)]
    return LineStyle(method, color, EXTRA_DASHES[(code // len(EXTRA_COLORS)) % len(EXTRA_DASHES)])


RC: dict[Any, Any] = {
    "font.size": 7.5,
    "axes.titlesize": 7.5,
    "axes.labelsize": 7.5,
    "legend.fontsize": 7,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "axes.grid": True,
    "grid.linewidth": 0.4,
    "grid.alpha": 0.5,
    "axes.linewidth": 0.6,
    "lines.linewidth": 0.9,
    "legend.frameon": False,
    # No "tight" bbox: constrained layout fits everything, and a file is exactly
    # figsize x dpi pixels (one paper column wide).
    "savefig.bbox": None,
    "svg.hashsalt": "coopproc",
    "pdf.compression": 6,
}
