"""A session's raw GNSS files read into :class:`~coopproc.gnss.receiver.GnssReceiver`\\ s.

DATA.md "Raw sensors": ``obs_<ID>.<yy>o`` / ``obs_<ID>.rnx`` (RINEX 2.x / 3.x
observations of platform ID's receiver) and the session's navigation files (``nav.rnx``,
``*_MN.rnx``, ``*.<yy>n``; all of them merged). Problems are one line each, naming the
file (and line, from the RINEX readers): an observation file without a navigation file,
of a platform the session does not have, gzip-compressed, in a session whose ``[time] base`` is
``relative`` (GPST epochs cannot be placed in it), or whose epochs fall outside the
session's time span by more than an hour. Each receiver read gets one note.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from coopproc import timeconv
from coopproc.errors import CoopprocError, InputError
from coopproc.gnss.ephemeris import GpsEphemerides
from coopproc.gnss.receiver import GnssReceiver
from coopproc.gnss.rinex_nav import read_navs
from coopproc.gnss.rinex_obs import read_obs
from coopproc.model import Platform, SensorFile, SessionConfig

__all__ = ["read_gnss"]

#: epochs may reach this far beyond the session's other data (s)
_SLACK_S = 3600.0


def _offset(config: SessionConfig, gpst_s: float, where: SensorFile) -> float:
    """session time = gpst - offset, for the session's time base."""
    if config.time_base == "gps_tow":
        if config.gps_week is None:
            week = int(gpst_s // timeconv.SECONDS_PER_WEEK)
        else:
            week = int(config.gps_week)
        return week * timeconv.SECONDS_PER_WEEK
    if config.time_base == "unix":
        return float(gpst_s - timeconv.gpst_to_unix(np.array([gpst_s]))[0])
    raise InputError(
        where.path,
        'GPS observations (GPST epochs) cannot be aligned with [time] base = "relative"; '
        "expected base gps_tow or unix in session.toml",
    )


def read_gnss(
    files: Sequence[SensorFile],
    platforms: Mapping[str, Platform],
    config: SessionConfig,
    span_s: tuple[float, float] | None,
    problems: list[CoopprocError],
    notes: list[str],
) -> dict[str, GnssReceiver]:
    """The receivers of ``files`` (kinds ``gnss_obs`` / ``gnss_nav``); problems and notes
    appended. ``span_s``: the session's time span (the ranges'), for the time check."""
    obs_files = sorted(
        (f for f in files if f.kind == "gnss_obs" and f.platform is not None),
        key=lambda f: str(f.path),
    )
    nav_files = sorted((f.path for f in files if f.kind == "gnss_nav"), key=str)
    if not obs_files:
        notes.extend(
            f"{n}: GNSS broadcast ephemerides without observation files (obs_<ID>.*); not used"
            for n in nav_files
        )
        return {}
    packed = [f for f in (*(o.path for o in obs_files), *nav_files) if f.suffix == ".gz"]
    if packed:
        problems.append(
            InputError(packed[0], "gzip-compressed RINEX is not read; expected it unpacked")
        )
        return {}
    eph: GpsEphemerides | None = None
    if not nav_files:
        problems.append(
            InputError(
                obs_files[0].path,
                "GPS observations without a navigation file; expected nav.rnx (or "
                "*_MN.rnx, *.<yy>n) in the session directory",
            )
        )
        return {}
    try:
        eph = read_navs(nav_files)
    except CoopprocError as err:
        problems.append(err)
        return {}
    out: dict[str, GnssReceiver] = {}
    for f in obs_files:
        pid = str(f.platform)
        if pid not in platforms:
            problems.append(
                InputError(
                    f.path,
                    f"GPS observations of platform {pid}, which the session does not have "
                    f"(platforms: {', '.join(sorted(platforms)) or 'none'}); expected "
                    f"nav_{pid}.csv or [platforms.{pid}] in session.toml",
                )
            )
            continue
        try:
            obs = read_obs(f.path)
            if obs.epoch_gpst_s.size == 0:
                raise InputError(f.path, "no observation epoch in the file")
            offset = _offset(config, float(obs.epoch_gpst_s[0]), f)
            receiver = GnssReceiver(pid, obs, eph, offset)
            _check_span(receiver, f, span_s)
        except CoopprocError as err:
            problems.append(err)
            continue
        out[pid] = receiver
        t = receiver.epoch_time_s
        notes.append(
            f"{f.path}: GPS observations of {pid} read ({t.size} epochs, "
            f"{t[-1] - t[0]:.1f} s, {len(nav_files)} navigation file(s))"
        )
    return out


def _check_span(receiver: GnssReceiver, f: SensorFile, span_s: tuple[float, float] | None) -> None:
    if span_s is None:
        return
    t = receiver.epoch_time_s
    a, b = span_s
    if t[-1] < a - _SLACK_S or t[0] > b + _SLACK_S:
        line = None if receiver.obs.epoch_line is None else int(receiver.obs.epoch_line[0])
        raise InputError(
            f.path,
            f"epochs {t[0]:.1f}..{t[-1]:.1f} (session time) do not overlap the session's "
            f"{a:.1f}..{b:.1f}; expected the same day and [time] gps_week",
            line=line,
        )
