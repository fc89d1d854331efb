"""UWB outages named by the user (paper 003 section 3.4): ranges withheld from every method.

``[run] outages = [[t0, t1], ...]`` (or ``coopproc run --outage T0:T1``, repeatable) names
windows in seconds from the session start (its first navigation or range epoch, as
``coopproc validate`` and ``coopproc inject`` count). :func:`run_with_outages` runs the
chain on the session without the ranges inside the windows (both ends included), so that
no range processor or position estimator sees them, and then

- lists them in ``ranges.csv`` all the same, in their places: ``observed`` and
  ``reference`` as measured, every method column empty (NaN, no processed value, as for a
  tag's pairs), ``nlos_flag`` 0 (no column is added: the contract stays; the windows and
  the count are in ``run.json`` ``outages``);
- reports the positions at the navigation rate (``positions_at = "nav"``): inside an
  outage there is no range epoch to report at, and the drift is what is wanted;
- scores every method's drift inside each window (:func:`coopproc.report.outage.outage_table`:
  ``outages.csv``).

Windows reaching outside the session, overlapping, or ending at or before their start
are a one-line :class:`~coopproc.errors.ConfigError`.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd

from coopproc.checks.coverage import session_start_s
from coopproc.errors import ConfigError, StageError
from coopproc.model import Session
from coopproc.report.outage import outage_table
from coopproc.run.pipeline_output import PipelineOutput
from coopproc.stages.ranging.table import observed_table

if TYPE_CHECKING:
    from coopproc.run.config import RunConfig

__all__ = [
    "OutageOutput",
    "OutageReport",
    "OutageWindow",
    "check_windows",
    "parse_outage",
    "run_with_outages",
    "withhold",
]


@dataclass(frozen=True)
class OutageWindow:
    """One window: seconds from the session start and in the session's time base."""

    start_s: float
    end_s: float
    #: the session start the relative times count from (session time base, s)
    origin_s: float

    @property
    def start(self) -> float:
        return self.origin_s + self.start_s

    @property
    def end(self) -> float:
        return self.origin_s + self.end_s

    @property
    def label(self) -> str:
        return f"{self.start_s:g}-{self.end_s:g} s"


@dataclass(frozen=True, eq=False)
class OutageReport:
    """What the run did with the windows: run.json ``outages`` and ``outages.csv``."""

    windows: tuple[OutageWindow, ...]
    #: ranges withheld in each window
    withheld: tuple[int, ...]
    #: outages.csv (:data:`coopproc.report.outage.OUTAGE_COLUMNS`)
    table: pd.DataFrame
    #: the positions_at the run used ("nav" when the config said "ranges")
    positions_at: str

    def facts(self) -> dict[str, Any]:
        """run.json ``outages``."""
        return {
            "windows": [
                {
                    "start_s": w.start_s,
                    "end_s": w.end_s,
                    "start": w.start,
                    "end": w.end,
                    "withheld": n,
                }
                for w, n in zip(self.windows, self.withheld, strict=True)
            ],
            "withheld": int(sum(self.withheld)),
            "positions_at": self.positions_at,
        }


@dataclass(frozen=True, eq=False)
class OutageOutput(PipelineOutput):
    """The output of a run with outage windows: the pipeline's plus :class:`OutageReport`."""

    outages: OutageReport | None = None


def parse_outage(text: str) -> tuple[float, float]:
    """``T0:T1`` (seconds from the session start) as two numbers; ValueError otherwise."""
    head, sep, tail = text.partition(":")
    try:
        if not sep:
            raise ValueError
        window = (float(head), float(tail))
    except ValueError:
        raise ValueError(
            f"{text!r} is not an outage window; expected T0:T1 in seconds from the session "
            "start, e.g. 100:130"
        ) from None
    if not all(np.isfinite(window)):
        raise ValueError(f"{text!r}: the times must be finite numbers")
    return window


def _session_end_s(session: Session) -> float:
    """The last navigation or range epoch, s (session time base)."""
    times = [float(session.ranges.frame["time"].max())] if len(session.ranges) else []
    times += [traj.span_s[1] for traj in session.nav.values() if len(traj)]
    return max(times) if times else 0.0


def check_windows(given: Sequence[Sequence[float]], session: Session) -> tuple[OutageWindow, ...]:
    """The windows in time order; ConfigError (one line) for a window that ends at or
    before its start, reaches outside the session, or overlaps another."""
    origin = session_start_s(session)
    length = _session_end_s(session) - origin
    windows = []
    for start, end in given:
        name = f"outage {start:g}:{end:g}"
        if not end > start:
            raise ConfigError(
                f"{name}: the end must be after the start (seconds from the session start)"
            )
        if start < 0.0 or end > length + 1e-6:
            raise ConfigError(
                f"{name}: reaches outside the session, which spans 0-{length:.1f} s from its "
                f"start {origin:.3f}"
            )
        windows.append(OutageWindow(float(start), float(end), origin))
    windows.sort(key=lambda w: w.start_s)
    for first, second in itertools.pairwise(windows):
        if second.start_s < first.end_s:
            raise ConfigError(
                f"outages {first.start_s:g}:{first.end_s:g} and {second.start_s:g}:"
                f"{second.end_s:g} overlap; give each stretch once"
            )
    return tuple(windows)


def _inside(times: np.ndarray, windows: Sequence[OutageWindow]) -> np.ndarray:
    out = np.zeros(times.shape[0], dtype=bool)
    for w in windows:
        out |= (times >= w.start - 1e-9) & (times <= w.end + 1e-9)
    return out


def withhold(session: Session, windows: Sequence[OutageWindow]) -> tuple[Session, list[int]]:
    """The session without the ranges inside the windows, and the count per window."""
    frame = session.ranges.frame
    times = frame["time"].to_numpy(dtype=np.float64)
    counts = [int(_inside(times, (w,)).sum()) for w in windows]
    keep = ~_inside(times, windows)
    ranges = dataclasses.replace(session.ranges, frame=frame[keep].reset_index(drop=True))
    return dataclasses.replace(session, ranges=ranges), counts


def _listed_again(full: pd.DataFrame, inner: pd.DataFrame, withheld: np.ndarray) -> pd.DataFrame:
    """ranges.csv of the whole session: the run's rows where kept, the withheld ones with
    their observed and reference distance and no processed value."""
    if len(inner) != int((~withheld).sum()):
        raise StageError(
            f"outages: the run's range table has {len(inner)} rows, expected "
            f"{int((~withheld).sum())} (the session's without the withheld ones)"
        )
    out = {}
    for col in inner.columns:
        if col in ("time", "pair", "observed", "reference"):
            out[col] = full[col].to_numpy()
            continue
        values = inner[col].to_numpy()
        flags = col in ("nlos_flag", "outlier")
        fill: Any = 0 if flags else (0.0 if col == "nlos_estimate" else np.nan)
        column = np.full(len(full), fill, dtype=values.dtype if flags else float)
        column[~withheld] = values
        out[col] = column
    return pd.DataFrame(out, columns=list(inner.columns))


def run_with_outages(
    session: Session,
    config: RunConfig,
    run: Callable[..., PipelineOutput],
    progress: Callable[[str], None] | None = None,
) -> PipelineOutput:
    """``run`` (:func:`coopproc.run.pipeline.run_pipeline`) on the session without the
    ranges of ``config.run.outages``; see the module docstring."""
    windows = check_windows(config.run.outages, session)
    kept, counts = withhold(session, windows)
    positions_at: Literal["ranges", "nav"] = "nav"
    inner_config = dataclasses.replace(
        config, run=dataclasses.replace(config.run, outages=(), positions_at=positions_at)
    )
    output = run(kept, inner_config, progress=progress)
    full = observed_table(session)
    withheld = _inside(full["time"].to_numpy(dtype=np.float64), windows)
    ranges = _listed_again(full, output.result.ranges, withheld)
    table = outage_table(output.result.positions, [(w.start, w.end) for w in windows])
    listed = ", ".join(f"{w.label} ({n})" for w, n in zip(windows, counts, strict=True))
    notes = [
        f"[run] outages: {sum(counts)} ranges withheld from every method in "
        f"{len(windows)} window{'s' if len(windows) > 1 else ''} ({listed}; seconds from the "
        "session start); ranges.csv lists them without processed values; drift per method "
        "in outages.csv"
    ]
    if config.run.positions_at != positions_at:
        notes.append(
            "[run] outages: positions.csv at the navigation rate (positions_at = 'nav'): "
            "inside an outage there is no range epoch to report at"
        )
    empty = [w.label for w, n in zip(windows, counts, strict=True) if n == 0]
    if empty:
        notes.append(f"[run] outages: no range inside {', '.join(empty)}")
    report = OutageReport(windows, tuple(counts), table, positions_at)
    fields = {f.name: getattr(output, f.name) for f in dataclasses.fields(output)}
    fields |= {
        "result": dataclasses.replace(output.result, ranges=ranges),
        "notes": (*notes, *output.notes),
    }
    return OutageOutput(**fields, outages=report)
