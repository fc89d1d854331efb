"""Panel titles and the figure legend that fit their page: nothing cut, nothing overprinted.

Two things the layouts of :mod:`coopproc.report.panels` do not see by themselves:

- **A title wider than its column.** The titles are left-aligned (``(a) A-B, event 1
  (t = 120 s)``), and matplotlib's constrained layout counts a title's height but not its
  width (``get_tightbbox(for_layout_only=True)`` makes it one pixel wide), so a long title
  runs into the next column's y label (the overprint) or out of the figure (the cut):
  ``--style single-column`` draws ``nlos_convergence`` two panels a row in 3.5 in, 1.2 in
  of room for 28 characters of 8 pt text (1.5 in). :func:`wrap_titles` breaks such a
  title onto two lines (after ``", "`` or before ``" ("``, else at a space), so the
  constrained layout, which does count the height, makes room for it.
- **A legend taller than the fixed top margin.** A grid of more than 6 panels has fixed
  margins in inches (:data:`coopproc.report.panels._FIXED_MARGINS_IN`; the constrained
  layout would cost 0.1 s a panel); its top margin of 0.62 in holds two legend rows and a
  title, and the trajectories of 10 platforms have three rows (7 entries). :func:`legend_room`
  makes the figure taller by what is missing, the panels keeping their size in inches.

Both measure the text with the Agg renderer at the figure's dpi, as it will be drawn.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from matplotlib.axes import Axes
from matplotlib.backend_bases import RendererBase
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text

__all__ = ["TITLE_GAP_PT", "legend_room", "renderer_of", "wrap_titles"]

#: Room kept between a title's end and the next column's decorations (or the figure
#: edge), and between the legend and the titles under it, points. Small: the panels
#: measured once the constrained layout has run stand up to 4 px (at 100 dpi) right of
#: where drawing the page puts them, so a title ending 6.5 pt from the edge (the
#: default style's ``(c) B-C, RN-Based event 1 (t = 51 s)``) is kept on one line.
TITLE_GAP_PT = 2.0
#: The constrained layout's padding around each panel's decorations (``w_pad``, 3 pt a
#: side by default): a title can start no further left than that from its cell.
_LAYOUT_PAD_PT = 3.0
#: Where a title may break: after ``", "`` or before ``" ("`` (not its leading ``(a)``).
_BREAKS = re.compile(r"(?<=,) | (?=\()")


def renderer_of(fig: Figure) -> RendererBase:
    """The figure's Agg renderer (an Agg canvas attached if it has none)."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    return canvas.get_renderer()


def _columns(axes: Sequence[Axes]) -> dict[Axes, tuple[int, int]]:
    """Each grid panel's (column, number of columns) from its subplot spec."""
    out = {}
    for ax in axes:
        spec = ax.get_subplotspec()
        if spec is not None:
            out[ax] = (spec.colspan.start, spec.get_gridspec().ncols)
    return out


def _room_px(fig: Figure, ax: Axes, renderer: RendererBase) -> float:
    """How wide the title of ``ax`` may be, pixels, with the panels where they are now:
    from the left of its panel to the decorations (y tick labels and label) of the next
    panel to its right in its row, else to the figure's edge, less :data:`TITLE_GAP_PT`."""
    x0 = ax.get_window_extent(renderer).x0
    ends = [fig.bbox.x1]
    for other in fig.axes:
        if other is ax or not _same_row(ax, other):
            continue
        if other.get_window_extent(renderer).x0 > x0 + 1.0:
            decorations = other.yaxis.get_tightbbox(renderer)
            ends.append((decorations or other.get_window_extent(renderer)).x0)
    return min(ends) - x0 - TITLE_GAP_PT * fig.dpi / 72.0


def _sure_room_px(fig: Figure, ax: Axes, ncols: int, renderer: RendererBase) -> float:
    """At least the room of :func:`_room_px` once the constrained layout has placed the
    panels, pixels, without running it: a ``1 / ncols`` share of the figure less the
    panel's own decorations on its left and the layout's pads (no title shorter than this
    needs the layout run to know that it fits)."""
    pad = _LAYOUT_PAD_PT * fig.dpi / 72.0
    box = ax.get_window_extent(renderer)
    yaxis = ax.yaxis.get_tightbbox(renderer)
    own = max(box.x0 - yaxis.x0, 0.0) if yaxis is not None else 0.0
    return fig.bbox.width / ncols - own - 2.0 * pad - TITLE_GAP_PT * fig.dpi / 72.0


def _same_row(a: Axes, b: Axes) -> bool:
    sa, sb = a.get_subplotspec(), b.get_subplotspec()
    if sa is None or sb is None:
        return False
    return sa.rowspan.start == sb.rowspan.start


def _width_px(title: Text, text: str, renderer: RendererBase) -> float:
    title.set_text(text)
    return float(title.get_window_extent(renderer).width)


def _wrapped(title: Text, room_px: float, renderer: RendererBase) -> str:
    """The title's text broken into lines that fit ``room_px`` where it can: greedily at
    :data:`_BREAKS`, a piece still too wide at its spaces (a word wider than the room
    stays whole)."""
    text = title.get_text()
    pieces: list[str] = []
    for piece in _BREAKS.split(text):
        if _width_px(title, piece, renderer) <= room_px:
            pieces.append(piece)
        else:
            pieces.extend(piece.split(" "))
    lines: list[str] = []
    for piece in pieces:
        joined = f"{lines[-1]} {piece}" if lines else piece
        if lines and _width_px(title, joined, renderer) <= room_px:
            lines[-1] = joined
        else:
            lines.append(piece)
    return "\n".join(lines)


def wrap_titles(fig: Figure, axes: Sequence[Axes], titles: Sequence[Text]) -> int:
    """Break each of ``titles`` (that of ``axes`` at the same place) wider than its
    column onto more lines (see the module docstring); how many were broken.

    A constrained layout is run once first when a title may not fit
    (:func:`_sure_room_px`), so that the room is measured where the panels will be."""
    renderer = renderer_of(fig)
    columns = _columns(axes)
    todo = [
        (ax, title)
        for ax, title in zip(axes, titles, strict=True)
        if ax in columns and title.get_text()
    ]
    engine = fig.get_layout_engine()
    if engine is not None:
        todo = [
            (ax, title)
            for ax, title in todo
            if _width_px(title, title.get_text(), renderer)
            > _sure_room_px(fig, ax, columns[ax][1], renderer)
        ]
        if todo:
            engine.execute(fig)
    else:  # a title within its own panel's width is clear of the next column's labels
        todo = [
            (ax, title)
            for ax, title in todo
            if _width_px(title, title.get_text(), renderer) > ax.get_window_extent(renderer).width
        ]
    broken = 0
    for ax, title in todo:
        text = title.get_text()
        room = _room_px(fig, ax, renderer)
        if _width_px(title, text, renderer) <= room:
            continue
        lines = _wrapped(title, room, renderer)
        title.set_text(lines)
        broken += lines != text
    return broken


def legend_room(fig: Figure, titles: Sequence[Text]) -> float:
    """Make a figure of fixed margins taller where its legend (above the panels) would
    reach down into the ``titles``, keeping every panel's size and place from the bottom
    in inches; the inches added (0 when it fits, or with a layout engine, which makes room
    by itself)."""
    if fig.get_layout_engine() is not None or not fig.legends:
        return 0.0
    renderer = renderer_of(fig)
    dpi = fig.dpi
    legend_bottom = min(leg.get_window_extent(renderer).y0 for leg in fig.legends)
    tops = [t.get_window_extent(renderer).y1 for t in titles if t.get_text()]
    if not tops:
        return 0.0
    short = (max(tops) + TITLE_GAP_PT * dpi / 72.0 - legend_bottom) / dpi
    if short <= 0.0:
        return 0.0
    width, height = fig.get_size_inches()
    # every axes where it is in inches from the bottom (panels, a colour bar below)
    placed = [(ax, ax.get_position()) for ax in fig.axes]
    grown = height + short
    fig.set_size_inches(width, grown)
    for ax, pos in placed:
        ax.set_position((pos.x0, pos.y0 * height / grown, pos.width, pos.height * height / grown))
    params = fig.subplotpars
    fig.subplotpars.update(bottom=params.bottom * height / grown, top=params.top * height / grown)
    return float(short)
