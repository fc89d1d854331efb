"""The INS position methods of paper 003 Table 1 (issue 12 items 4-5): ``ins`` (UWB/INS,
ranges to anchors tightly coupled, lever arm), ``ins_nhc`` (+ NHC, + odometer when the
platform has one), ``ins_rts`` and ``ins_nhc_rts`` (the forward filters followed by the RTS
smoother over the full error state). With ``lsq`` (UWB robust least squares) they are
Table 1's five modes in one run (docs/methods-ins.md, "In the pipeline").

Each mode is a position estimator of the chain (:mod:`coopproc.stages.registry`) that
runs on the observed ranges only, for every platform with an IMU (``imu_<ID>.csv`` or an
MCAP/bag Imu topic) and ranges to anchors. A filtered mode and its smoothed mode share one
engine run (:func:`coopproc.ins.engine.run_ins` with ``smooth=True``): the first of them
to run computes it, the second takes it from :data:`_CACHE`. Positions are reported at the
platform's range epochs (``[run] positions_at = "ranges"``) or its navigation epochs
(``"nav"``; 10 Hz of the IMU for a platform without one), interpolated from the IMU-rate
solution; velocity and attitude go to states.csv.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.base import NavStates, PositionInput, PositionProduct, PositionStage
from coopproc.stages.ins.ins_setup import anchor_ranges, ins_start, odometer_scale

__all__ = [
    "INS_MODES",
    "INS_STAGES",
    "InsParams",
    "dead_reckoning",
    "ins_platforms",
    "ins_solution",
]

#: The INS modes in Table 1 order (filtered, then smoothed).
INS_MODES: tuple[str, ...] = ("ins", "ins_nhc", "ins_rts", "ins_nhc_rts")


@dataclass(frozen=True)
class InsParams:
    """The INS methods (run config ``[ins]``)."""

    modes: tuple[str, ...] = field(
        default=INS_MODES,
        metadata={
            "help": "INS methods added to [pipeline] positions (with lsq) when a platform "
            "has an IMU and ranges to anchors and the chain names none; [] = off "
            "(ins, ins_nhc, ins_rts, ins_nhc_rts)"
        },
    )
    navigation: Literal["given", "ins"] = field(
        default="given",
        metadata={
            "help": "the navigation of platforms with an IMU and a nav file, for the "
            "cooperative fusion and the DI stage: 'given' = the nav file; 'ins' = the INS "
            "dead reckoning (IMU + NHC + odometer, no UWB) started from the nav file"
        },
    )
    robust: bool = field(default=True, metadata={"help": "IGG-III on the innovations"})
    k0: float = field(default=3.0, metadata={"help": "IGG-III k0 (paper 002: 2.5..3.5)"})
    k1: float = field(
        default=4.5,
        metadata={"help": "IGG-III k1 (paper 002: 3.5..4.5)"},
    )
    range_sigma_m: float = field(
        default=0.15,
        metadata={"help": "range 1-sigma (m) for rows without one when session.toml has none"},
    )
    nhc_sigma_mps: float = field(
        default=0.1, metadata={"help": "NHC 1-sigma, lateral and vertical velocity (m/s)"}
    )
    odo_sigma_mps: float = field(
        default=0.05, metadata={"help": "odometer forward-speed 1-sigma (m/s)"}
    )
    odo_calibrate: bool = field(
        default=True,
        metadata={
            "help": "divide the odometer speed by its scale (1 + k) estimated against the "
            "smoothed UWB/INS solution (ins_rts) before ins_nhc runs; the filter has no "
            "odometer-scale state (docs/methods-ins.md)"
        },
    )
    zupt: bool = field(
        default=True,
        metadata={
            "help": "zero-velocity updates while the IMU and the odometer say the platform "
            "is at rest (only with an odometer, in ins_nhc / ins_nhc_rts)"
        },
    )
    start_sigma_m: float = field(
        default=1.0, metadata={"help": "1-sigma of the start position (m, each axis)"}
    )
    start_sigma_mps: float = field(
        default=0.3, metadata={"help": "1-sigma of the start velocity (m/s, each axis)"}
    )
    tag_up_m: float = field(
        default=0.0,
        metadata={
            "help": "start height (m, up) of the IMU of a platform without a navigation "
            "file (a tag); anchors at similar heights hardly observe it"
        },
    )
    level_sigma_deg: float = field(
        default=2.0, metadata={"help": "roll/pitch 1-sigma when aligned in motion (deg)"}
    )
    heading_sigma_deg: float = field(
        default=10.0, metadata={"help": "heading 1-sigma when aligned in motion (deg)"}
    )
    heading_search: int = field(
        default=12,
        metadata={
            "help": "start headings tried when neither a navigation heading nor "
            "gyrocompassing gives one (the best fit of the ranges is taken; 0 = the first "
            "motion's heading alone; docs/methods-ins.md, Start)"
        },
    )
    search_window_s: float = field(
        default=30.0,
        metadata={"help": "seconds of motion (after a static start) each heading is tried on"},
    )

    def __post_init__(self) -> None:
        for mode in self.modes:
            if mode not in INS_MODES:
                raise ValueError(f"unknown INS mode '{mode}' (known: {', '.join(INS_MODES)})")
        if not 0 < self.k0 < self.k1:
            raise ValueError(f"k0 = {self.k0}, k1 = {self.k1}: expected 0 < k0 < k1")
        if self.heading_search < 0 or self.search_window_s <= 0:
            raise ValueError(
                f"heading_search = {self.heading_search}, search_window_s = "
                f"{self.search_window_s}: expected >= 0 and > 0"
            )
        for name in ("range_sigma_m", "nhc_sigma_mps", "odo_sigma_mps", "start_sigma_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} = {getattr(self, name)}, expected > 0")


def ins_platforms(session: Session) -> list[str]:
    """Platforms (not anchors) with IMU samples, in session order."""
    return [
        p
        for p in session.platform_ids
        if p in session.imu and session.platforms[p].role != "anchor"
    ]


#: (session, ranges, nhc) -> (platform -> engine result, notes); one session at a time
_CACHE: dict[tuple[int, int, bool], tuple[Session, pd.DataFrame, dict[str, Any], list[str]]] = {}


def ins_solution(
    session: Session, ranges: pd.DataFrame, params: InsParams, *, nhc: bool
) -> tuple[dict[str, Any], list[str]]:
    """Every IMU platform's UWB/INS(/NHC) run with smoothing (cached), and notes."""
    key = (id(session), id(ranges), nhc)
    hit = _CACHE.get(key)
    if hit is not None and hit[0] is session and hit[1] is ranges:
        return hit[2], hit[3]
    if any(entry[0] is not session for entry in _CACHE.values()):
        _CACHE.clear()
    out: dict[str, Any] = {}
    notes: list[str] = []
    scales: dict[str, float] = {}
    if nhc and params.odo_calibrate and any(p in session.odometer for p in ins_platforms(session)):
        plain, _ = ins_solution(session, ranges, params, nhc=False)
        for platform, res in plain.items():
            odo = session.odometer.get(platform)
            k = (
                None
                if odo is None
                else odometer_scale(odo.time_s, odo.speed_mps, res.best, res.time_s)
            )
            if k is not None:
                scales[platform] = k
    for platform in ins_platforms(session):
        if nhc and platform not in session.odometer and session.platforms[platform].nhc is False:
            # nothing to add to ins (a multirotor): its run, not a second start-up search
            plain, _ = ins_solution(session, ranges, params, nhc=False)
            if platform in plain:
                out[platform] = plain[platform]
                notes.append(f"INS of {platform}: ins_nhc = ins (nhc = false, no odometer)")
            continue
        got = _run_platform(
            session, platform, ranges, params, nhc=nhc, uwb=True, odo_scale=scales.get(platform)
        )
        if got is None:
            notes.append(f"INS: {platform} has no ranges to anchors; no INS solution")
            continue
        out[platform], note = got
        notes.append(note)
    _CACHE[key] = (session, ranges, out, notes)
    return out, notes


def _run_platform(
    session: Session,
    platform: str,
    ranges: pd.DataFrame | None,
    params: InsParams,
    *,
    nhc: bool,
    uwb: bool,
    odo_scale: float | None = None,
) -> tuple[Any, str] | None:
    """One platform's engine run: UWB/INS(/NHC) with smoothing, or (``uwb=False``) the
    INS/NHC/odometer dead reckoning without (forward only)."""
    from coopproc.ins.engine import InsAiding, InsConfig, RangeObs, SpeedObs, run_ins
    from coopproc.ins.models import imu_figures

    imu = session.imu[platform]
    cfg = session.platforms[platform]
    range_obs = None
    if uwb:
        assert ranges is not None
        t, point, rng, sigma = anchor_ranges(session, platform, ranges, params.range_sigma_m)
        if t.size < 4:
            return None
        lever = np.asarray(cfg.uwb_lever_arm_m or (0.0, 0.0, 0.0), dtype=np.float64)
        range_obs = RangeObs(t, point, rng, sigma, lever)
    speed = None
    odo = session.odometer.get(platform)
    if nhc and odo is not None:
        v = odo.speed_mps if odo_scale is None else odo.speed_mps / (1.0 + odo_scale)
        speed = SpeedObs(odo.time_s, v, np.full(odo.time_s.shape, params.odo_sigma_mps))
    use_nhc = nhc and cfg.nhc is not False
    start = ins_start(
        session,
        imu,
        ranges if uwb else None,
        level_sigma_deg=params.level_sigma_deg,
        heading_sigma_deg=params.heading_sigma_deg,
        tag_up_m=params.tag_up_m,
    )
    aiding = InsAiding(
        ranges=range_obs,
        speed=speed,
        nhc=use_nhc,
        nhc_sigma_mps=(params.nhc_sigma_mps, params.nhc_sigma_mps),
        zupt=params.zupt and speed is not None,  # the IMU alone takes a steady drive for rest
        robust=(params.k0, params.k1) if params.robust else None,
    )
    config = InsConfig(
        figures=imu_figures(cfg.imu),
        origin_llh=tuple(session.origin_llh),  # type: ignore[arg-type]
        alignment=start.alignment,
        start_enu=start.enu_m,
        start_vel_enu=start.vel_enu_mps,
        sigma_pos_m=params.start_sigma_m,
        sigma_vel_mps=params.start_sigma_mps,
        smooth=uwb,
    )
    how = start.how
    if start.search and uwb and params.heading_search > 0:
        from coopproc.ins.startup import START_NIS_MAX, start_up

        n_static = start.alignment.static_samples
        static_s = float(imu.time_s[n_static - 1] - imu.time_s[0]) if n_static > 1 else 0.0
        found = start_up(
            imu, aiding, config, static_s=static_s, window_s=params.search_window_s,
            count=params.heading_search,
        )  # fmt: skip
        config = dataclasses.replace(found.config, smooth=config.smooth)
        how = f"{how}; heading by {found.describe()}"
        if found.refined_nis > START_NIS_MAX:
            how += (
                f"; warning: no candidate fits its ranges (NIS RMS above {START_NIS_MAX:g}): "
                "the start may be wrong; a navigation file with a heading, a static start "
                "of 5 s or denser ranges would give one"
            )
    result = run_ins(imu, aiding, config)
    used = ["UWB ranges to anchors" if uwb else "no UWB"]
    used += ["NHC"] if use_nhc else []
    if speed is not None:
        used += [
            "odometer" + ("" if odo_scale is None else f" (scale {odo_scale:+.2%} vs ins_rts)")
        ]
    return result, f"INS of {platform}: {', '.join(used)}; start: {how}"


def dead_reckoning(session: Session, platform: str, params: InsParams) -> tuple[Trajectory, str]:
    """The INS/NHC/odometer dead reckoning of a platform with an IMU and a navigation file
    (no UWB; forward filter), at the navigation file's epochs inside the IMU's span."""
    got = _run_platform(session, platform, None, params, nhc=True, uwb=False)
    assert got is not None  # without UWB there is always a run
    result, note = got
    t = session.nav[platform].time_s
    t = t[(t >= result.time_s[0]) & (t <= result.time_s[-1])]
    traj, _ = track_at(platform, t, result.time_s, result.forward, "INS dead reckoning")
    return traj, f"the INS dead reckoning ({note.split(': ', 1)[1]})"


def output_epochs(session: Session, platform: str, ranges: pd.DataFrame, output: str) -> FloatArray:
    """The epochs a platform's INS solution is reported at (module docstring)."""
    imu_t = session.imu[platform].time_s
    if output == "ranges":
        frame = ranges
        mine = (frame["from"].to_numpy() == platform) | (frame["to"].to_numpy() == platform)
        t = np.unique(frame["time"].to_numpy(np.float64)[mine])
    elif platform in session.nav:
        t = session.nav[platform].time_s
    else:
        step = max(1, round(0.1 / float(np.median(np.diff(imu_t)))))
        t = imu_t[::step]
    return np.asarray(t[(t >= imu_t[0]) & (t <= imu_t[-1])], dtype=np.float64)


def _interp(t: FloatArray, tt: FloatArray, values: FloatArray) -> FloatArray:
    return np.column_stack([np.interp(t, tt, values[:, i]) for i in range(values.shape[1])])


def track_at(
    platform: str, time_s: FloatArray, t_imu: FloatArray, track: Any, source: str
) -> tuple[Trajectory, NavStates]:
    """(Trajectory, NavStates) of an engine track at ``time_s``: attitude converted to
    roll (right side down), pitch (nose up), yaw = heading clockwise from north (deg)."""
    enu = _interp(time_s, t_imu, track.enu_m)
    sig = _interp(time_s, t_imu, track.sigma_enu)
    vel = _interp(time_s, t_imu, track.vel_enu)
    att = np.radians(track.att_deg)
    att = np.unwrap(att, axis=0)
    a = np.degrees(_interp(time_s, t_imu, att))
    att_out = np.column_stack([a[:, 0], -a[:, 1], np.mod(90.0 - a[:, 2], 360.0)])
    nan = np.full((time_s.size, 3), np.nan)
    vel_sig = getattr(track, "sigma_vel", None)
    att_sig = getattr(track, "sigma_att_deg", None)
    states = NavStates(
        time_s,
        vel,
        att_out,
        nan if vel_sig is None else _interp(time_s, t_imu, vel_sig),
        nan if att_sig is None else _interp(time_s, t_imu, att_sig),
    )
    heading = att_out[:, 2]
    traj = Trajectory(
        platform, time_s, enu, sigma_enu_m=sig, vel_enu_mps=vel, heading_deg=heading, source=source
    )
    return traj, states


def _stage(mode: str) -> Callable[[PositionInput, InsParams], PositionProduct]:
    nhc = "nhc" in mode
    smoothed = mode.endswith("_rts")

    def run(inp: PositionInput, params: InsParams) -> PositionProduct:
        results, notes = ins_solution(inp.session, inp.ranges, params, nhc=nhc)
        positions: dict[str, Trajectory] = {}
        states: dict[str, NavStates] = {}
        for platform, result in results.items():
            track = result.smoothed if smoothed else result.forward
            t = output_epochs(inp.session, platform, inp.ranges, inp.output)
            positions[platform], states[platform] = track_at(
                platform, t, result.time_s, track, f"INS ({mode})"
            )
        first = mode in ("ins", "ins_nhc")  # the notes once per engine run
        return PositionProduct(
            positions=positions, states=states, notes=tuple(notes) if first else ()
        )

    return run


def _check(session: Session) -> None:
    if not ins_platforms(session):
        raise StageError(
            "ins: no platform has an IMU (imu_<ID>.csv or an Imu topic); the INS methods "
            "need raw IMU samples"
        )
    if not any(p.role == "anchor" for p in session.platforms.values()):
        raise StageError(
            "ins: the session has no anchors (platforms with role 'anchor'); the INS "
            "methods integrate UWB ranges to anchors"
        )


_HELP = {
    "ins": "UWB/INS: ranges to anchors tightly coupled with the IMU, lever arm, IGG-III "
    "(paper 003 Table 1), forward filter",
    "ins_nhc": "UWB/INS/NHC: ins + non-holonomic constraints + odometer, forward filter",
    "ins_rts": "UWB/INS/RTS: ins followed by the RTS smoother over the full error state",
    "ins_nhc_rts": "UWB/INS/NHC/RTS: ins_nhc followed by the RTS smoother",
}

INS_STAGES: tuple[PositionStage, ...] = tuple(
    PositionStage(
        name=mode,
        params_type=InsParams,
        section="ins",
        run=_stage(mode),
        help=_HELP[mode] + "; observed ranges only",
        check=_check,
        uwb_only=True,
        requires=frozenset({"imu", "anchors"}),
        observed_only=True,
    )
    for mode in INS_MODES
)
