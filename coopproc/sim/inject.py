"""``coopproc inject``: the papers' error experiments on a session of one's own.

:func:`inject_session` writes a new session: a copy of SESSION (every file byte for byte,
``session.toml`` and ``truth/`` included) whose ranges file has the injected errors, plus
``injected.csv`` listing every range it changed or removed (:mod:`coopproc.io.injected`),
so that ``coopproc run`` can score the methods against what was injected. The input
session is never modified; the output is written atomically.

- **NLOS** (paper 000 sec. 4.3): "we simulated the NLOS error by adding a group of numbers
  that obey normal distribution to the measured data", N(0.45, 0.1^2) etc. over 10-20 s:
  one draw of N(mean, sd^2) per range in the window (not a constant mean plus noise),
  added to the observed range. Table 1 scores the estimates against the distribution's
  mean ("reference value"), so ``injected_scores.csv`` does too.
- **Gross errors** (paper 002 sec. 5.4, Tables 6-7: "a gross error of 2 m is added onto a
  UWB range measurement" at a chosen epoch): ``size`` metres added to the range of the
  pair nearest to the chosen time (both rows when two share that time).
- **UWB outages** (paper 003 sec. 3.4: "six UWB signal-blocked periods ... each lasting
  for 30 seconds"): every range in the window removed, of every pair or of the chosen
  ones.

The draws are seeded (``numpy.random.default_rng(seed)``, one call per NLOS event in the
order given), so the same session, events and seed give byte-identical files. An NLOS or
gross error on a range an outage removes is not added (an NLOS event left with no range,
or a gross error whose range is removed, is refused).
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.errors import ConfigError, InputError, OutputError
from coopproc.io import read_session
from coopproc.io.injected import INJECTED_COLUMNS, INJECTED_FILE, write_injected
from coopproc.io.outdir import atomic_output_dir, check_output_dir
from coopproc.io.registry import find_files
from coopproc.sim.inject_csv import RangesText, add_decimal, read_ranges_text, write_ranges_text
from coopproc.sim.inject_plan import Injection, resolve_injection
from coopproc.sim.inject_truth import update_truth

__all__ = ["InjectionResult", "inject_session", "injection_records"]

#: data row, kind, error, event, start, end, mean, sd
_Record = tuple[int, str, float, str, float, float, float, float]


@dataclass(frozen=True)
class InjectionResult:
    """What :func:`inject_session` wrote."""

    out_dir: Path
    #: the rows of injected.csv
    records: pd.DataFrame
    #: the resolved events (absolute times, the session's pair names)
    injection: Injection
    notes: tuple[str, ...] = ()

    def summary(self) -> str:
        """One line: what was injected, how many ranges each kind touched."""
        kinds = self.records["kind"].to_numpy(dtype=object)
        inj = self.injection
        parts = []
        for count, word, kind, verb in (
            (len(inj.nlos), "NLOS event", "nlos", ""),
            (len(inj.gross), "gross error", "gross", ""),
            (len(inj.outages), "outage", "outage", " removed"),
        ):
            if count:
                n = int(np.count_nonzero(kinds == kind))
                ranges = "range" if n == 1 else "ranges"
                parts.append(f"{count} {word}{'s' if count > 1 else ''} ({n} {ranges}{verb})")
        return (
            f"{self.out_dir}: {', '.join(parts)}, seed {inj.seed}; each range in "
            f"{self.out_dir / INJECTED_FILE}"
        )


def _outages(text: RangesText, injection: Injection) -> tuple[list[_Record], dict[int, str]]:
    """The outages' records and, per removed data row, the option that removes it."""
    t, pair = text.time_s, text.pair
    records: list[_Record] = []
    removed_by: dict[int, str] = {}
    for n, o in enumerate(injection.outages, start=1):
        start, end = float(o.start), float(o.end)
        mask = (t >= start) & (t <= end)
        if o.pairs:
            mask &= np.isin(pair, list(o.pairs))
        for k in np.flatnonzero(mask):
            removed_by.setdefault(int(k), o.option())
            records.append(
                (int(k), "outage", math.nan, f"outage{n}", start, end, math.nan, math.nan)
            )
    return records, removed_by


def injection_records(
    text: RangesText, injection: Injection
) -> tuple[pd.DataFrame, dict[int, float], set[int]]:
    """What ``injection`` (resolved) does to the rows of ``text``: the injected.csv rows
    (plus the data row ``row`` of each), the error added per data row, the rows removed."""
    rng = np.random.default_rng(injection.seed)
    t, pair = text.time_s, text.pair
    outage_records, removed_by = _outages(text, injection)
    records: list[_Record] = []
    for n, ev in enumerate(injection.nlos, start=1):
        start, end = float(ev.start), float(ev.end)
        idx = np.flatnonzero((pair == ev.pair) & (t >= start) & (t <= end))
        # paper 000 sec. 4.3: one draw per range epoch, rounded to the micrometre that
        # the files hold (the recorded error is exactly what the new file adds); drawn
        # for every range in the window, so an outage does not shift the later draws
        draws = np.round(rng.normal(ev.mean, ev.sd, idx.size), 6)
        kept = [(int(k), float(e)) for k, e in zip(idx, draws, strict=True) if k not in removed_by]
        if not kept:
            raise ConfigError(f"{ev.option()}: every range in the window is removed by --outage")
        records += [(k, "nlos", e, f"nlos{n}", start, end, ev.mean, ev.sd) for k, e in kept]
    for n, g in enumerate(injection.gross, start=1):
        time = float(g.time)
        cand = np.flatnonzero(pair == g.pair)
        gap = np.abs(t[cand] - time)
        for k in (int(k) for k in cand[gap == gap.min()]):
            if k in removed_by:
                raise ConfigError(
                    f"{g.option()}: its nearest range (at {t[k]:.3f}) is removed by {removed_by[k]}"
                )
            records.append(
                (k, "gross", round(g.size, 6), f"gross{n}", time, time, g.size, math.nan)
            )
    records += outage_records
    frame = pd.DataFrame(
        records, columns=["row", "kind", "error", "event", "start", "end", "mean", "sd"]
    )
    row = frame["row"].to_numpy(dtype=np.int64)
    frame.insert(0, "time", t[row])
    frame.insert(1, "pair", pair[row])
    # each event's rows in time order (a file's rows may not be), events in the given order
    frame["order"] = pd.Categorical(frame["event"], categories=frame["event"].unique()).codes
    frame = frame.sort_values(["order", "time", "row"], kind="stable").reset_index(drop=True)
    added: dict[int, float] = {}
    for k, e in zip(frame["row"], frame["error"], strict=True):
        if np.isfinite(e):
            added[int(k)] = round(added.get(int(k), 0.0) + float(e), 6)
    return frame.drop(columns=["order"]), added, set(removed_by)


def _copy_session(root: Path, dest: Path, skip: Path) -> None:
    """Every file under ``root`` into ``dest`` (existing), byte for byte, except ``skip``."""

    def ignore(directory: str, names: list[str]) -> list[str]:
        return [n for n in names if (Path(directory) / n).resolve() == skip]

    shutil.copytree(root, dest, ignore=ignore, dirs_exist_ok=True)


def _check_paths(root: Path, out: Path) -> None:
    if root.is_file() or root.name.lower().endswith(".mcap"):
        raise InputError(
            root,
            "an .mcap recording; coopproc inject does not support MCAP sessions yet: "
            "expected a session directory with a ranges.csv",
        )
    if not root.is_dir():
        raise InputError(root, "no such session directory")
    if (root / INJECTED_FILE).exists():
        raise InputError(
            root / INJECTED_FILE,
            "this session was made by coopproc inject; inject into the original session, "
            "every event in one call",
        )
    if out.resolve() == root.resolve():
        raise OutputError(f"{out}: refusing to write output over the input session")
    if out.resolve().is_relative_to(root.resolve()):
        raise OutputError(f"{out}: inside the session {root}; expected a path outside it")


def inject_session(
    session: str | Path, out: str | Path, injection: Injection, *, force: bool = False
) -> InjectionResult:
    """Write a copy of ``session`` with ``injection`` applied into ``out`` (module doc).

    ``out`` must not exist (or be empty) unless ``force``; errors are one line
    (ConfigError for the events, InputError for the session, OutputError for ``out``).
    """
    root, out_dir = Path(session), Path(out)
    _check_paths(root, out_dir)
    check_output_dir(out_dir, force=force, protect=[root])
    data = read_session(root)
    files = find_files(root, data.config)
    if files.ranges is None:
        where = files.mcap.name if files.mcap is not None else "no ranges file"
        raise InputError(
            root,
            f"the ranges come from {where}; coopproc inject does not support MCAP ranges "
            "yet: expected a ranges.csv",
        )
    resolved = resolve_injection(injection, data)
    text = read_ranges_text(files.ranges)
    records, added, removed = injection_records(text, resolved)
    cells = {k: add_decimal(text.range_text[k], e) for k, e in added.items()}
    for k, cell in cells.items():
        if float(cell) < 0:
            raise ConfigError(
                f"the range of {text.pair[k]} at {text.time_s[k]:.3f} would be negative "
                f"({cell} m); choose a smaller negative gross error"
            )
    ranges_rel = files.ranges.relative_to(root)
    with atomic_output_dir(out_dir, force=force, protect=[root, *data.inputs]) as tmp:
        _copy_session(root, tmp, files.ranges.resolve())
        write_ranges_text(text, tmp / ranges_rel, cells, removed)
        write_injected(records[list(INJECTED_COLUMNS)], tmp / INJECTED_FILE)
        notes = update_truth(tmp / "truth", text, records, added, removed)
    return InjectionResult(out_dir, records[list(INJECTED_COLUMNS)], resolved, tuple(notes))
