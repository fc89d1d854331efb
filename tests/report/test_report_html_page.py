"""report.html reads as a page: notes as a list, human names in every table, cells that do
not wrap, every figure at one scale, a page without figures when asked (parsed with
html.parser, not matched as text)."""

from __future__ import annotations

import base64
import io
from html.parser import HTMLParser
from pathlib import Path

import pytest
from PIL import Image
from report_synth import make_run
from test_report_rundir import write_run_dir

from coopproc.report.html import render_html
from coopproc.report.html_figures import DISPLAY_PX_PER_IN
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run
from coopproc.report.scores import NLOS_EVENT_SCORE_COLUMNS

NOTES = [
    "ref_A.pos: 101 of 3001 epochs with Q not in [1] dropped from the reference",
    "ref_B.pos: 62 of 3001 epochs with Q not in [1] dropped from the reference",
]
#: Method names as the tables write them: the CSV keys must not show.
RAW_METHODS = {"observed", "rn", "di", "nav", "reference"}


class Page(HTMLParser):
    """What the tests look at: table cells per table, note items, images, style text."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[dict[str, list[str]]] = []
        self.notes: list[str] = []
        self.images: list[dict[str, str]] = []
        self.style = ""
        self.wide_tables = 0
        self._stack: list[str] = []
        self._text: list[str] = []
        self._wide_depth = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "div" and a.get("class") == "wide":
            self._wide_depth += 1
        if tag == "table":
            self.tables.append({"th": [], "td": [], "class": [a.get("class", "")]})
            self.wide_tables += self._wide_depth > 0
        if tag == "img":
            self.images.append(a)
        if tag == "ul" and a.get("class") == "notes":
            self._stack.append("notes")
        if tag in ("th", "td", "li", "style"):
            self._stack.append(tag)
            self._text = []

    def handle_endtag(self, tag: str) -> None:
        if tag == "div" and self._wide_depth:
            self._wide_depth -= 1
        if tag in ("th", "td", "li", "style") and self._stack and self._stack[-1] == tag:
            self._stack.pop()
            text = "".join(self._text).strip()
            if tag == "style":
                self.style += text
            elif tag == "li" and self._stack and self._stack[-1] == "notes":
                self.notes.append(text)
            elif tag in ("th", "td") and self.tables:
                self.tables[-1][tag].append(text)
        if tag == "ul" and self._stack and self._stack[-1] == "notes":
            self._stack.pop()

    def handle_data(self, data: str) -> None:
        self._text.append(data)


def parse(page: str) -> Page:
    parsed = Page()
    parsed.feed(page)
    parsed.close()
    return parsed


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, RunTables]:
    out = write_run_dir(make_run(n=80), tmp_path_factory.mktemp("page") / "out")
    loaded = load_run(out)
    return out, RunTables(**{**vars(loaded), "info": {**loaded.info, "notes": NOTES}})


def test_notes_are_list_items(run: tuple[Path, RunTables]) -> None:
    page = render_html(run[0], run[1], figures=False)
    assert parse(page).notes == NOTES
    assert " | " not in page


def test_tables_show_human_names(run: tuple[Path, RunTables]) -> None:
    page = parse(render_html(run[0], run[1], figures=False))
    classes = [t["class"][0] for t in page.tables]
    assert {"table2", "table3", "nlos", "nlos_events"} <= set(classes)
    for table in page.tables:
        assert not RAW_METHODS & set(table["td"]), table["class"]
        raw = [h for h in table["th"] if "_" in h or h in NLOS_EVENT_SCORE_COLUMNS]
        assert not raw, (table["class"], raw)
    events = page.tables[classes.index("nlos_events")]
    assert events["th"] == [
        "Pair",
        "Method",
        "Start (s)",
        "End (s)",
        "Epochs",
        "Estimate (m)",
        "Reference bias (m)",
        "Error (m)",
    ]
    assert {"DI-Based", "RN-Based"} <= set(events["td"])
    # start and end in s since t0, as the figures' time axes (make_run: t0 = 1000 s)
    assert "30.0" in events["td"] and "1030.0000" not in events["td"]


def test_cells_do_not_wrap_and_tables_scroll(run: tuple[Path, RunTables]) -> None:
    page = parse(render_html(run[0], run[1], figures=False))
    rule = next(r for r in page.style.split("}") if r.strip().startswith("th, td"))
    assert "white-space: nowrap" in rule
    assert page.wide_tables == len(page.tables) - 1  # all but the run's Inputs table


def _png_width_in(src: str) -> float:
    png = base64.b64decode(src.split(",", 1)[1])
    with Image.open(io.BytesIO(png)) as image:
        return image.width / round(float(image.info["dpi"][0]))  # PNG keeps dots per metre


@pytest.mark.slow  # every figure drawn for the page
def test_every_figure_at_one_scale(run: tuple[Path, RunTables]) -> None:
    """One-column (3.5 in) and full-width (7 in) figures: the same pixels per inch."""
    page = parse(render_html(run[0], run[1]))
    assert len(page.images) >= 5
    widths = {round(_png_width_in(img["src"]), 2) for img in page.images}
    assert len(widths) > 1  # figures of different widths ...
    for img in page.images:  # ... each shown at DISPLAY_PX_PER_IN
        assert int(img["width"]) == round(_png_width_in(img["src"]) * DISPLAY_PX_PER_IN)


def test_a_page_without_figures_says_so(run: tuple[Path, RunTables]) -> None:
    page = render_html(run[0], run[1], figures=False)
    assert not parse(page).images and "<img" not in page
    assert "<h2>Figures</h2>" in page and "coopproc run --no-figures" in page


@pytest.mark.slow
def test_linked_thumbnails_keep_the_scale(
    run: tuple[Path, RunTables], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A reduced copy (linked figures) is shown as wide as its full figure would be."""
    from coopproc.report import html_figures
    from coopproc.report.figures import write_figures

    out = write_run_dir(make_run(n=80), tmp_path / "out")
    files = write_figures(load_run(out), out / "figures", dpi=60)
    monkeypatch.setattr(html_figures, "EMBED_LIMIT_BYTES", 1)
    monkeypatch.setattr(html_figures, "THUMBNAIL_WIDTH_PX", 100)
    page = parse(render_html(out, load_run(out)))
    assert len(page.images) == len(files)
    for img, path in zip(page.images, files, strict=True):
        with Image.open(path) as image:
            full_px = image.width
        small = base64.b64decode(img["src"].split(",", 1)[1])
        with Image.open(io.BytesIO(small)) as image:
            assert image.width == 100 < full_px  # the reduced copy ...
        assert int(img["width"]) == round(full_px / 60.0 * DISPLAY_PX_PER_IN)  # ... full scale
