"""The Figures section of ``report.html``: embedded while small, linked when large.

Every page of every figure (:func:`~coopproc.report.figures.figure_pages`) is shown from
its ``OUT/figures/<stem>.png`` when that file holds the same panels (its ``Panels`` text
chunk; files without one are taken as they are), else rendered in memory from the tables.

- When every page has its file and the files total at most :data:`EMBED_LIMIT_BYTES`,
  they are embedded as they are (base64): the page is one self-contained file.
- Otherwise the page stays small: each figure shows a reduced copy of its first page
  (:data:`THUMBNAIL_WIDTH_PX` wide) linking to the full PNG, and its further pages are
  links; a note says so. A page with no file is rendered at 150 dpi and embedded while
  the embedded images stay under the limit, else left out with a note.

Every image is shown at one scale, :data:`DISPLAY_PX_PER_IN` CSS pixels per inch of the
figure (its width in pixels over the resolution its PNG records), so text and lines have
the same size in every figure, one journal column wide or the full text width (narrower
screens shrink them all alike).

The section also says which pairs and platforms the figures leave out (``--pairs``,
``--platforms``, or the cap on pages of :mod:`coopproc.report.panel_cap`: each capped
figure's caption says what it drew, lists what it left out and how to draw it) and how a
figure of many panels is split into pages.
"""

from __future__ import annotations

import base64
import html
import io
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib as mpl

from coopproc.report.figures import PANEL_SEPARATOR, PANELS_KEY, FigurePage, figure_pages
from coopproc.report.pages import FigureOptions, panel_letter, selection_note
from coopproc.report.panel_cap import Capped
from coopproc.report.run_tables import RunTables
from coopproc.report.style import RC

__all__ = ["DISPLAY_PX_PER_IN", "EMBED_LIMIT_BYTES", "THUMBNAIL_WIDTH_PX", "figures_section"]

#: Most bytes of PNG embedded in report.html (base64 adds a third).
EMBED_LIMIT_BYTES = 3_000_000
#: Width of the reduced first page shown when the figures are linked.
THUMBNAIL_WIDTH_PX = 1000
#: Resolution of pages rendered in memory (no file in OUT/figures).
_RENDER_DPI = 150
#: CSS pixels per inch of figure in the page: the widest figure style (7.16 in) fits the
#: page's 1200 px; a one-column figure (3.5 in) is shown half as wide, at the same scale.
DISPLAY_PX_PER_IN = 150
#: Resolution assumed for a PNG that records none (matplotlib's savefig records it).
_DEFAULT_DPI = 300.0
#: Width, inches, given to a figure file PIL cannot read (the double-column style's).
_FALLBACK_WIDTH_IN = 7.16


def _file_panels(path: Path) -> tuple[str, ...] | None:
    """The panel keys recorded in a PNG's text chunk, None if it has none (or is no PNG)."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            text = image.info.get(PANELS_KEY)
    except (OSError, ValueError):
        return None
    return None if not isinstance(text, str) else tuple(text.split(PANEL_SEPARATOR))


def _usable(path: Path, page: FigurePage) -> bool:
    if not path.is_file():
        return False
    panels = _file_panels(path)
    return panels is None or panels == page.keys


def _thumbnail(png: bytes) -> bytes:
    """A copy of a PNG at most :data:`THUMBNAIL_WIDTH_PX` wide, in 256 colours."""
    from PIL import Image

    with Image.open(io.BytesIO(png)) as image:
        image.load()
        small = image.convert("RGB")
    if small.width > THUMBNAIL_WIDTH_PX:
        height = max(1, round(small.height * THUMBNAIL_WIDTH_PX / small.width))
        small = small.resize(
            (THUMBNAIL_WIDTH_PX, height), Image.Resampling.BILINEAR, reducing_gap=2.0
        )
    buf = io.BytesIO()
    small.quantize(256, method=Image.Quantize.FASTOCTREE).save(buf, format="PNG")
    return buf.getvalue()


def _render(page: FigurePage) -> bytes:
    buf = io.BytesIO()
    with mpl.rc_context(RC):
        page.draw().savefig(buf, format="png", dpi=_RENDER_DPI, metadata={"Software": None})
    return buf.getvalue()


def _width_in(png: bytes) -> float:
    """The figure's width in inches: pixels over the PNG's recorded resolution."""
    from PIL import Image

    try:
        with Image.open(io.BytesIO(png)) as image:
            dpi = image.info.get("dpi")
            width = image.width
    except (OSError, ValueError):  # not a PNG PIL reads: shown as wide as the widest style
        return _FALLBACK_WIDTH_IN
    # PNG stores dots per metre: 300 dpi reads back as 299.9994, so whole dpi
    x_dpi = round(float(dpi[0])) if isinstance(dpi, tuple) and dpi else 0
    return width / (x_dpi if x_dpi > 0 else _DEFAULT_DPI)


def _img(alt: str, png: bytes, href: str | None = None, *, width_in: float) -> str:
    """An embedded image shown :data:`DISPLAY_PX_PER_IN` per inch of figure."""
    data = base64.b64encode(png).decode("ascii")
    width = round(width_in * DISPLAY_PX_PER_IN)
    img = f'<img alt="{alt}" src="data:image/png;base64,{data}" width="{width}">'
    return f'<a href="{html.escape(href)}">{img}</a>' if href else img


def _span(page: FigurePage) -> str:
    """``panels (a)-(x): A-B ... C-D`` of one page."""
    first, last = panel_letter(page.first), panel_letter(page.first + len(page.keys) - 1)
    labels = f"({first})" if first == last else f"({first})–({last})"
    keys = page.keys[0] if len(page.keys) == 1 else f"{page.keys[0]} … {page.keys[-1]}"
    return f"panels {labels}: {keys}"


def _pages_note(pages: Sequence[FigurePage], linked: set[str]) -> str:
    """How a figure of several pages is split, each page a link where it has a file."""
    head = pages[0]
    items = []
    for page in pages:
        file = f"figures/{page.stem}.png"
        name = f'<a href="{file}">{file}</a>' if page.stem in linked else f"{page.stem}"
        items.append(f"{name} ({html.escape(_span(page))})")
    return (
        f'<p class="note">{head.total} panels on {head.count} pages of at most '
        f"{len(head.keys)}: {'; '.join(items)}.</p>"
    )


def _capped_note(capped: Capped) -> str:
    """What a capped figure drew, how to draw the rest, and every panel it left out."""
    note = re.sub(r"`([^`]+)`", r"<code>\1</code>", html.escape(capped.note()))
    return f'<p class="note">{note} Left out: {html.escape("; ".join(capped.left_out))}.</p>'


def figures_section(
    out_dir: Path,
    run: RunTables,
    options: FigureOptions | None = None,
    captions: Mapping[str, str] | None = None,
    pages: Sequence[FigurePage] | None = None,
) -> str:
    """The ``<h2>Figures</h2>`` section (see the module docstring); ``captions`` by
    figure name; ``pages``: those of ``figure_pages(run, options)`` if already listed."""
    opts = options or FigureOptions()
    pages = list(figure_pages(run, opts) if pages is None else pages)
    fig_dir = Path(out_dir) / "figures"
    files = {p.stem: fig_dir / f"{p.stem}.png" for p in pages}
    usable = {p.stem for p in pages if _usable(files[p.stem], p)}
    sizes = {s: files[s].stat().st_size for s in usable}
    embed_all = len(usable) == len(pages) and sum(sizes.values()) <= EMBED_LIMIT_BYTES
    parts = ["<h2>Figures</h2>"]
    note = selection_note(run, opts)
    if note:
        parts.append(f'<p class="note">{html.escape(note)}</p>')
    if pages and not embed_all and usable:
        parts.append(
            '<p class="note">The figure files are linked, not embedded: together '
            f"{sum(sizes.values()) / 1e6:.1f} MB, more than the "
            f"{EMBED_LIMIT_BYTES / 1e6:.0f} MB this page embeds. Each figure shows a reduced "
            "copy of its first page; click it (or a page link) for the full PNG in figures/ "
            "next to this file.</p>"
        )
    embedded = 0
    left_out: list[str] = []
    by_name: dict[str, list[FigurePage]] = {}
    for page in pages:
        by_name.setdefault(page.name, []).append(page)
    for name, fig_pages in by_name.items():
        caption = html.escape((captions or {}).get(name, name))
        body = []
        for page in fig_pages:
            if page.stem in usable:
                png = files[page.stem].read_bytes()
                if embed_all:
                    body.append(_img(page.stem, png, width_in=_width_in(png)))
                elif page.index == 0:
                    small, href = _thumbnail(png), f"figures/{page.stem}.png"
                    body.append(_img(page.stem, small, href, width_in=_width_in(png)))
                continue
            png = _render(page)
            if embed_all or embedded + len(png) <= EMBED_LIMIT_BYTES:
                embedded += len(png)
                body.append(_img(page.stem, png, width_in=_width_in(png)))
            else:
                left_out.append(page.stem)
        if len(fig_pages) > 1:
            caption += _pages_note(fig_pages, usable)
        if fig_pages[0].capped is not None:
            caption += _capped_note(fig_pages[0].capped)
        parts.append(
            f'<figure id="fig-{name}">{"".join(body)}<figcaption>{caption}</figcaption></figure>'
        )
    if left_out:
        parts.append(
            f'<p class="note">Not shown, to keep this page under '
            f"{EMBED_LIMIT_BYTES / 1e6:.0f} MB of images: {', '.join(left_out)}; "
            "`coopproc report OUT --plots` writes every page to OUT/figures.</p>"
        )
    return "\n".join(parts)
