"""read_session / validate_session: a session directory, one .mcap file or a ROS bag -> Session.

Both run the same loader; it reads every file even after a problem (skipping only the
checks that a failed file makes meaningless), so ``validate_session`` lists every problem
and ``read_session`` raises the first.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Literal

import numpy as np

from coopproc.errors import CoopprocError, InputError
from coopproc.io import assemble
from coopproc.io._common import (
    InputProblems,
    RawTrajectory,
    expand,
    flat,
)
from coopproc.io.csv_mapping import CsvForms
from coopproc.io.gnss_session import read_gnss
from coopproc.io.mcap_read import McapContent, decode_mcap, read_mcap_raw
from coopproc.io.plausible import apply_plausible, check_plausible
from coopproc.io.ranges_csv import RangesRead, read_ranges_csv
from coopproc.io.raw_sensors import attach_decoded, bag_imu, read_raw_sensors
from coopproc.io.registry import find_files, read_trajectory, sensor_note
from coopproc.io.rosbag_read import BagContent, session_bag
from coopproc.io.rosbag_scan import bag_files, is_bag
from coopproc.io.session_toml import TomlRead, mcap_mapping, parse_session_toml, read_session_toml
from coopproc.io.time_offsets import subtract_offsets
from coopproc.io.timebase import TimedFile, WeekSource, check_times, infer_time_base, span_problem
from coopproc.model import SensorFile, Session, SessionConfig

__all__ = ["inspect_session", "read_session", "validate_session"]

#: Raw-sensor kinds read into the session (the others are listed, with a note).
RAW_READ = ("imu", "odo", "gnss_obs", "gnss_nav")
#: Input files read at once.
READ_THREADS = 2


class _Loader:
    def __init__(self, strict: bool = False) -> None:
        #: --strict: a single-row glitch is a problem, not a row excluded with a note.
        self.strict = strict
        self.problems: list[CoopprocError] = []
        self.notes: list[str] = []
        self.inputs: list[Path] = []
        self.failed: set[str] = set()  # platforms whose nav could not be read
        self.sensors: list[SensorFile] = []  # raw-sensor files (imu, odo read; others listed)
        self.bag: tuple[Path, BagContent] | None = None  # its IMU and odometry
        self.decoded: list[tuple[Path, McapContent]] = []  # an MCAP file's IMU, odometry

    def add(self, err: CoopprocError) -> None:
        if isinstance(err, InputProblems):
            self.problems.extend(err.errors)
        else:
            self.problems.append(err)

    def load(self, path: str | Path) -> Session | None:
        root = Path(path)
        if not root.exists():
            raise InputError(root, "no such file or directory; expected a session directory")
        toml: TomlRead | None = None
        nav_raw: dict[str, RawTrajectory] = {}
        ref_raw: dict[str, RawTrajectory] = {}
        ranges: RangesRead | None = None
        mcap_path: Path | None = None
        if root.is_dir():
            toml_path = root / "session.toml"
            if toml_path.is_file():
                self.inputs.append(toml_path)
                try:
                    toml = read_session_toml(toml_path)
                except CoopprocError as err:
                    self.add(err)
                    self.failed.add("<toml>")
            config = toml.config if toml else SessionConfig()
            files = find_files(root, config)
            forms = toml.forms if toml else CsvForms()
            self.problems.extend(files.problems)
            self.notes.extend(files.notes)
            self.sensors = files.sensors
            self.notes.extend(sensor_note(f) for f in files.sensors if f.kind not in RAW_READ)
            # The files are read READ_THREADS at a time (pandas' C parser releases the GIL);
            # their results and problems are taken in the same order as one by one.
            with ThreadPoolExecutor(max_workers=READ_THREADS) as pool:
                if files.ranges is not None:  # the largest file first
                    later = pool.submit(read_ranges_csv, files.ranges, forms.form("ranges"))
                reads = [
                    (kind, pid, target, fpath)
                    for kind, group, target in (
                        ("nav", files.nav, nav_raw),
                        ("ref", files.ref, ref_raw),
                    )
                    for pid, fpath in sorted(group.items())
                ]
                pending = [
                    pool.submit(read_trajectory, fpath, pid, forms.form(f"{kind}.{pid}"))
                    for kind, pid, _, fpath in reads
                ]
                for (kind, pid, target, fpath), read in zip(reads, pending, strict=True):
                    self.inputs.append(fpath)
                    try:
                        target[pid] = read.result()
                    except CoopprocError as err:
                        self.add(err)
                        if kind == "nav":
                            self.failed.add(pid)
                if files.ranges is not None:
                    self.inputs.append(files.ranges)
                    try:
                        ranges = later.result()
                    except CoopprocError as err:
                        self.add(err)
                        self.failed.add("<ranges>")
            mcap_path = files.mcap
        elif root.name.lower().endswith(".mcap"):
            mcap_path = root
        elif not is_bag(root):
            raise InputError(
                root, "not a session; expected a session directory or an .mcap file (or a ROS bag)"
            )
        if mcap_path is not None and (mcap_path.parent / "metadata.yaml").is_file():
            mcap_path = None  # the storage of a ROS 2 bag folder: read as the bag
        if mcap_path is not None:
            self.inputs.append(mcap_path)
            toml, content = self._mcap(mcap_path, toml)
            if content is not None:
                ranges = self._merge(content, nav_raw, ref_raw, ranges, mcap_path)
                self.decoded.append((mcap_path, content))
        if "<toml>" not in self.failed:  # a ROS bag: rosbag_read.py, [topics]
            try:
                found = session_bag(root, toml.topics if toml else None)
            except CoopprocError as err:
                self.add(err)
                self.failed.add("<ranges>")
                found = None
            if found is not None:
                self.inputs.extend(bag_files(found[0]))
                self.sensors.extend(found[1].sensors)
                self.bag = found
                self.decoded.append(found)
                ranges = self._merge(found[1], nav_raw, ref_raw, ranges, found[0])
        config = toml.config if toml else SessionConfig()
        if toml is None:
            self.notes.append("no session.toml: every figure takes its default")
        return self._assemble(root, config, toml, nav_raw, ref_raw, ranges)

    def _mcap(
        self, path: Path, toml: TomlRead | None
    ) -> tuple[TomlRead | None, McapContent | None]:
        try:
            raw = read_mcap_raw(path)
        except CoopprocError as err:
            self.add(err)
            self.failed.add("<ranges>")
            return toml, None
        embedded = raw.attachments.get("session.toml")
        if embedded is not None and toml is None and "<toml>" not in self.failed:
            try:
                toml = parse_session_toml(
                    embedded.decode("utf-8", "replace"), f"{path} session.toml"
                )
            except CoopprocError as err:
                self.add(err)
                self.failed.add("<toml>")
        elif embedded is not None:
            self.notes.append(f"{path.name}: embedded session.toml ignored; session.toml used")
        try:
            mapping = mcap_mapping(toml.config if toml else SessionConfig())
            return toml, decode_mcap(raw, mapping)
        except CoopprocError as err:
            self.add(err)
            self.failed.add("<ranges>")
            return toml, None

    def _merge(
        self,
        content: McapContent,
        nav_raw: dict[str, RawTrajectory],
        ref_raw: dict[str, RawTrajectory],
        ranges: RangesRead | None,
        path: Path,
    ) -> RangesRead | None:
        self.notes.extend(content.notes)
        for group, target, what in (
            (content.nav, nav_raw, "nav"),
            (content.reference, ref_raw, "ref"),
        ):
            for pid, raw in group.items():
                if pid in target:
                    self.add(
                        InputError(path, f"{what} of {pid} given twice (also {target[pid].source})")
                    )
                else:
                    target[pid] = raw
        if content.ranges is not None and ranges is not None:
            self.add(InputError(path, f"ranges given twice (also {ranges.where.path})"))
        return ranges if content.ranges is None else content.ranges

    def _assemble(
        self,
        root: Path,
        config: SessionConfig,
        toml: TomlRead | None,
        nav_raw: dict[str, RawTrajectory],
        ref_raw: dict[str, RawTrajectory],
        ranges: RangesRead | None,
    ) -> Session | None:
        for raw in (*nav_raw.values(), *ref_raw.values()):
            self.notes.extend(raw.notes)
        if ranges is not None:
            self.notes.extend(ranges.notes)
        if (
            not nav_raw
            and not self.failed
            and not any(p.role == "anchor" for p in config.platforms.values())
        ):
            self.add(
                InputError(root, "no navigation files; expected nav_<ID>.csv (or .mcap /<ID>/nav)")
            )
        if ranges is None and "<ranges>" not in self.failed:
            self.add(InputError(root, "no ranges; expected ranges.csv (or .mcap /uwb/range)"))
        # Time base.
        config, bad_times, ranges = self._time_base(config, toml, nav_raw, ref_raw, ranges)
        # Reference quality filter.
        for pid in sorted(ref_raw):
            kept, note = assemble.filter_quality(ref_raw[pid], tuple(config.reference_quality))
            if note:
                self.notes.append(note)
            if kept.time_s.size == 0:
                self.notes.append(f"reference of {pid} has no accepted epoch; not used")
                del ref_raw[pid]
            else:
                ref_raw[pid] = kept
        origin, note = assemble.choose_origin(config, ref_raw, nav_raw)
        if note:
            self.notes.append(note)
        nav = {p: assemble.to_trajectory(r, origin) for p, r in sorted(nav_raw.items())}
        reference = {p: assemble.to_trajectory(r, origin) for p, r in sorted(ref_raw.items())}
        platforms = assemble.platforms_of(
            config, set(nav) | self.failed - {"<ranges>"}, self.notes, self.problems
        )
        platforms = {p: v for p, v in platforms.items() if p not in self.failed}
        # positions and velocities against the platforms' roles (io/plausible.py)
        plausible = check_plausible(
            nav_raw, ref_raw, nav, reference, platforms,
            None if ranges is None else ranges.table, strict=self.strict,
        )  # fmt: skip
        self.problems.extend(plausible.problems)
        self.notes += apply_plausible(plausible, (nav_raw, ref_raw), (nav, reference), origin)
        tags = {p for p, v in platforms.items() if v.role == "tag"}  # no navigation by design
        for pid in sorted(set(reference) - set(nav) - tags):
            self.notes.append(f"reference of {pid} has no navigation beside it")
        for pid in sorted(set(reference) & set(nav)):
            if not {nav[pid].source, reference[pid].source} & bad_times:
                apart = span_problem(nav[pid], reference[pid])
                if apart is not None:
                    self.add(apart)
        if ranges is not None:
            skip = self.failed - {"<ranges>"}
            if "<toml>" in self.failed:  # anchors unknown: do not blame ranges for them
                skip |= {str(pid) for pid in ranges.table.id_codes[0]}
            spans = {} if ranges.where.path in bad_times else nav
            spans = {p: t for p, t in spans.items() if t.source not in bad_times}
            self.problems.extend(assemble.check_ranges(ranges, platforms, nav, skip, spans))
        imu, odometer = read_raw_sensors(self.sensors, platforms, nav, self.problems, self.notes)
        for where, content in self.decoded:
            found = attach_decoded(
                content.imu_data, content.odometer, where, platforms, self.problems, self.notes
            )
            imu.update(found[0])
            odometer.update(found[1])
        if self.bag is not None:
            bag, samples = self.bag
            imu.update(bag_imu(samples.imu, bag, platforms, self.problems, self.notes))
        span = ranges.table.frame["time"] if ranges is not None else None
        gnss = read_gnss(  # obs_<ID>.* and the nav files (io.gnss_session)
            self.sensors,
            platforms,
            config,
            None if span is None or not len(span) else (float(span.min()), float(span.max())),
            self.problems,
            self.notes,
        )
        if self.problems or ranges is None:
            return None
        return Session(
            config=config,
            platforms=platforms,
            nav=nav,
            reference=reference,
            ranges=ranges.table,
            origin_llh=origin,
            root=root,
            inputs=tuple(dict.fromkeys(self.inputs)),
            notes=tuple(self.notes),
            sensor_files=tuple(self.sensors),
            imu=imu,
            odometer=odometer,
            gnss=gnss,
        )

    def _time_base(
        self,
        config: SessionConfig,
        toml: TomlRead | None,
        nav_raw: dict[str, RawTrajectory],
        ref_raw: dict[str, RawTrajectory],
        ranges: RangesRead | None,
    ) -> tuple[SessionConfig, set[str], RangesRead | None]:
        """Choose the base and week, convert GPST files to it, subtract the
        ``[time.offsets]``, check every file's times.

        Returns the config with the base and week used, the files whose times do not
        fit (their span checks would only repeat the problem), and the ranges.
        """
        own = [
            TimedFile(r.source, r.time_s, "nav")
            for r in nav_raw.values()
            if r.time_kind == "session"
        ]
        if ranges is not None:
            times = ranges.table.frame["time"].to_numpy(dtype=np.float64)
            own.append(TimedFile(ranges.where.path, times, "ranges"))
        base = config.time_base
        inferred_from = None
        given = bool(toml and toml.base_given)
        if not given:
            base, inferred_from = infer_time_base(own)  # type: ignore[assignment]
            self.notes.append(f"[time] base not given: {base} assumed from the times")
        week = WeekSource(config.gps_week, toml=toml.source if toml else None)
        gpst = [ref_raw[p] for p in sorted(ref_raw) if ref_raw[p].time_kind == "gpst"]
        gpst += [nav_raw[p] for p in sorted(nav_raw) if nav_raw[p].time_kind == "gpst"]
        if base == "gps_tow" and week.week is None and gpst:
            week = WeekSource(gpst[0].gps_week, taken_from=gpst[0].source)
            self.notes.append(
                f"[time] gps_week not given: week {week.week} of {gpst[0].source} used"
            )
        config = replace(config, time_base=base, gps_week=week.week)
        files: list[TimedFile] = []
        groups: tuple[tuple[Literal["nav", "ref"], dict[str, RawTrajectory]], ...] = (
            ("nav", nav_raw),
            ("ref", ref_raw),
        )
        for role, group in groups:
            for pid in sorted(group):
                raw = group[pid]
                try:
                    group[pid] = assemble.to_session_time(raw, base, week.week)
                except CoopprocError as err:
                    self.add(err)
                    del group[pid]
                    continue
                absolute = raw.gps_week if raw.time_kind == "gpst" else None
                files.append(TimedFile(raw.source, group[pid].time_s, role, absolute))
        if config.time_offsets and not isinstance(config.time_offsets, str):  # [time.offsets]
            where = toml.source if toml else "session.toml"
            ranges = subtract_offsets(
                config.time_offsets, where, nav_raw, ref_raw, ranges, files, self
            )
            own = [f for f in own if f.role != "ranges"]
            if ranges is not None:
                times = ranges.table.frame["time"].to_numpy(dtype=np.float64)
                own.append(TimedFile(ranges.where.path, times, "ranges"))
        files += [f for f in own if f.role == "ranges"]
        problems, bad = check_times(
            files, base, base_given=given, inferred_from=inferred_from, week=week
        )
        self.problems.extend(problems)
        return config, bad, ranges


def read_session(path: str | Path, *, strict: bool = False) -> Session:
    """Read and validate a session directory or one ``.mcap`` file.

    Raises the first problem found as InputError / ConfigError (one line: file, line or
    record, what was found and what was expected); ``validate_session`` lists them all.
    ``strict``: a single-row glitch is a problem, not a row excluded (io/plausible.py).
    """
    loader = _Loader(strict)
    session = loader.load(path)
    if loader.problems:
        raise flat(loader.problems[0])
    if session is None:  # pragma: no cover - every None path records a problem
        raise InputError(path, "no session could be read")
    return session


def validate_session(path: str | Path) -> list[str]:
    """Every problem of a session, one line each; empty when it reads cleanly."""
    return inspect_session(path)[1]


def inspect_session(path: str | Path, *, strict: bool = False) -> tuple[Session | None, list[str]]:
    """The session (None when it has problems) and every problem, one line each.

    What ``coopproc validate`` needs from one read: the problems, and the session for
    the checks that only warn (coverage, frames). ``strict`` as :func:`read_session`.
    """
    loader = _Loader(strict)
    session = None
    try:
        session = loader.load(path)
    except CoopprocError as fatal:
        loader.add(fatal)
    out: list[str] = []
    for err in loader.problems:
        for line in expand(err):
            if line not in out:
                out.append(line)
    return (None if out else session), out
