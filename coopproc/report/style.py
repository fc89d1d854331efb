"""The one place that fixes how each method and series looks in every figure.

Colours follow paper 000 where its captions say (fig. 11/12: observed blue solid, RN-Based
green dashed, DI-Based orange dash-dotted; fig. 8: cooperative positioning blue dashed,
dead reckoning orange solid, smoothed green dash-dotted). The figure sizes and
fonts come from a :class:`FigureStyle` (``--style default|single-column|double-column``,
:data:`STYLES`); its ``rc`` (``RC`` for the default) is applied with
``matplotlib.rc_context`` around figure making only; nothing here changes global state.
"""

from __future__ import annotations

import dataclasses
import zlib
from dataclasses import dataclass
from typing import Any

from coopproc.errors import ConfigError
from coopproc.report.table_specs import METHOD_LABELS, method_label

__all__ = [
    "COLUMN_WIDTH_IN",
    "DEFAULT_STYLE",
    "DI_STYLES",
    "DRAWN_DPI",
    "EXTRA_COLORS",
    "EXTRA_DASHES",
    "MAX_LINE_POINTS",
    "MAX_PAGES",
    "MAX_PANELS",
    "METHOD_STYLES",
    "NLOS_SPAN",
    "PANEL_HEIGHT_IN",
    "RC",
    "STYLES",
    "STYLE_NAMES",
    "WIDE_WIDTH_IN",
    "FigureStyle",
    "LineStyle",
    "figure_style",
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
#: Most pages a figure draws unless ``--pairs`` / ``--platforms`` chose its panels: 48
#: panels, every pair of 10 platforms; beyond, the panels most worth looking at
#: (:mod:`coopproc.report.panel_cap`). ``--max-pages`` / ``[run] max_pages``; 0: all.
MAX_PAGES = 2
#: The resolution the time-series lines are decimated for (``write_figures``' default
#: dpi): two points per pixel column of the panel (:func:`coopproc.report.decimate.panel_points`).
DRAWN_DPI = 300
#: Most points drawn per line and panel: longer series are drawn from their min/max
#: envelope (:mod:`coopproc.report.decimate`): two points a pixel column of the widest
#: panel (7 in at 300 dpi: 2100 columns); statistics always use every sample.
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
    # the display names are table_specs.METHOD_LABELS' (one definition, the registry's
    # RangeStage.labels for rn/di: tests/report/test_method_labels.py)
    "observed": LineStyle(METHOD_LABELS["observed"], "#1f77b4", "-", 0.8),
    "rn": LineStyle(METHOD_LABELS["rn"], "#2ca02c", "--"),
    "di": LineStyle(METHOD_LABELS["di"], "#ff7f0e", "-."),
    "nav": LineStyle(METHOD_LABELS["nav"], "#7f7f7f", ":"),
    "reference": LineStyle("Reference", "#000000", "-", 1.2),
    # paper 003 Table 1's UWB/INS modes (coopproc/stages/ins/ins_stage.py): a colour per
    # aiding, dashed forward, solid smoothed
    "ins": LineStyle("ins", "#9467bd", "--"),
    "ins_rts": LineStyle("ins_rts", "#5b2a86", "-"),
    "ins_nhc": LineStyle("ins_nhc", "#d62728", "--"),
    "ins_nhc_rts": LineStyle("ins_nhc_rts", "#8b0000", "-", 1.1),
    # the odometer + UWB filter (stages/odometry/odo_uwb.py): the same pattern in green (by
    # checksum odo_uwb had the colour of ins)
    "odo_uwb": LineStyle("odo_uwb", "#1a9e77", "--"),
    "odo_uwb_rts": LineStyle("odo_uwb_rts", "#0b5d46", "-"),
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
#: (none of them a fixed method's colour: "#9467bd", ins's, became "#a6761d")
EXTRA_COLORS: tuple[str, ...] = ("#a6761d", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#393b79")
EXTRA_DASHES: tuple[Any, ...] = ((0, (3, 1, 1, 1)), (0, (5, 1.5)), (0, (1, 1)))


def method_style(method: str) -> LineStyle:
    """The style of a method, labelled by :func:`~coopproc.report.table_specs.method_label`
    (the run's own names). A method beyond the known ones gets a colour and dash pattern
    from :data:`EXTRA_COLORS` / :data:`EXTRA_DASHES` chosen by a checksum of its name: the
    same in every figure and every run."""
    label = method_label(method)
    if method in METHOD_STYLES:  # its own label ("Reference") unless a name is declared
        known = METHOD_STYLES[method]
        if label == method or label == known.label:
            return known
        return dataclasses.replace(known, label=label)
    code = zlib.crc32(method.encode("utf-8"))
    color = EXTRA_COLORS[code % len(EXTRA_COLORS)]
    return LineStyle(label, color, EXTRA_DASHES[(code // len(EXTRA_COLORS)) % len(EXTRA_DASHES)])


#: Settings every style shares (grid, line widths, reproducible files).
_BASE_RC: dict[Any, Any] = {
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


@dataclass(frozen=True)
class FigureStyle:
    """Widths and font sizes of the figures (``--style``). Figures are saved at their
    print size, so a font size here is the size on paper.

    ``column_width_in``: a figure of one column of panels (stacked time series, one
    panel); ``wide_width_in``: a grid of ``max_columns`` panels a row (fewer panels a row
    take ``two_columns_share`` of it for two); ``row_scale`` scales the height of grid rows.
    """

    name: str
    column_width_in: float
    wide_width_in: float
    max_columns: int
    text_pt: float
    small_pt: float
    row_scale: float = 1.0
    two_columns_share: float = 0.67

    def grid_width_in(self, ncols: int) -> float:
        """Width of a figure of ``ncols`` panels a row."""
        if ncols <= 1:
            return self.column_width_in
        if ncols == 2 and self.max_columns > 2:
            return self.wide_width_in * self.two_columns_share
        return self.wide_width_in

    @property
    def rc(self) -> dict[Any, Any]:
        """The matplotlib settings of this style (for ``matplotlib.rc_context``)."""
        return {
            "font.size": self.text_pt,
            "axes.titlesize": self.text_pt,
            "axes.labelsize": self.text_pt,
            "legend.fontsize": self.small_pt,
            "xtick.labelsize": self.small_pt,
            "ytick.labelsize": self.small_pt,
            **_BASE_RC,
        }


#: ``default``: one-column stacks (3.5 in), grids up to 3 panels a row at 7 in, 7-7.5 pt;
#: ``single-column``: every figure one journal column wide (IEEE 3.5 in = 88.9 mm), at
#: most 2 panels a row, 8 pt; ``double-column``: every figure the full text width of a
#: two-column page (IEEE 7.16 in = 181.9 mm), up to 3 panels a row, 9 pt text, 8 pt ticks
#: and legend.
STYLES: dict[str, FigureStyle] = {
    "default": FigureStyle("default", COLUMN_WIDTH_IN, WIDE_WIDTH_IN, 3, 7.5, 7.0),
    "single-column": FigureStyle(
        "single-column", 3.5, 3.5, 2, 8.0, 8.0, row_scale=0.8, two_columns_share=1.0
    ),
    "double-column": FigureStyle("double-column", 7.16, 7.16, 3, 9.0, 8.0, two_columns_share=1.0),
}
STYLE_NAMES: tuple[str, ...] = tuple(STYLES)
DEFAULT_STYLE = STYLES["default"]


def figure_style(name: str) -> FigureStyle:
    """The style called ``name``; an unknown name raises ConfigError listing them."""
    if name not in STYLES:
        raise ConfigError(
            f"unknown figure style {name!r}; expected one of {', '.join(STYLE_NAMES)}"
        )
    return STYLES[name]


#: The settings of the default style.
RC: dict[Any, Any] = DEFAULT_STYLE.rc
