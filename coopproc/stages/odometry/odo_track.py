"""Odometer + UWB filter input: its parameters and one platform's steps and ranges.

For each platform with an odometer (``odo_<ID>.csv``) and ranges to fixed anchors, the
steps of the filter (:mod:`coopproc.stages.odometry.odo_kernel`) are the odometer and range
times; each step holds the odometer sample at or before its start (zero-order hold
forward). The yaw rate comes from the odometer (wheel speeds + wheelbase, or a twist),
else from the platform's IMU (z gyro averaged over each odometer interval); a platform
with neither is left out with a note. The initial position is the first robust least-
squares fix (:func:`coopproc.stages.shared.lsq.lsq_fixes` with the epoch spanning one
polling round of the anchors), its sigma widened by the odometer distance travelled
until then. The height for the 2D range model is the platform's nav height, else
``tag_up_m``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from coopproc.model import FloatArray, Session
from coopproc.stages.shared.data import anchor_positions, clean_ranges, range_sigma_default
from coopproc.stages.shared.lsq import LsqParams, lsq_fixes

__all__ = ["OdoTrack", "OdoUwbParams", "head_of", "odo_tracks"]


@dataclass(frozen=True)
class OdoUwbParams:
    """Odometer + UWB filter (run config ``[odo_uwb]``)."""

    auto: bool = field(
        default=True,
        metadata={
            "help": "add odo_uwb and odo_uwb_rts to [pipeline] positions when a platform "
            "has an odometer with a yaw rate and ranges to anchors"
        },
    )
    speed_sigma_mps: float = field(
        default=0.0,
        metadata={"help": "wheel-speed noise, 1-sigma per sample (m/s); 0: maximum likelihood"},
    )
    yaw_rate_sigma_radps: float = field(
        default=0.0,
        metadata={"help": "yaw-rate noise, 1-sigma per sample (rad/s); 0: maximum likelihood"},
    )
    range_sigma_scale: float = field(
        default=0.0,
        metadata={
            "help": "factor on the declared range sigma (rows' sigma, else [uwb] sigma); "
            "0: maximum likelihood"
        },
    )
    search_yaw_scale: bool = field(
        default=True,
        metadata={"help": "choose the yaw-rate scale (sign, wheelbase) by maximum likelihood"},
    )
    calib_distance_m: float = field(
        default=15.0,
        metadata={"help": "travel (odometer) over which the heading and yaw scale are chosen"},
    )
    speed_scale_sigma: float = field(
        default=0.05, metadata={"help": "initial 1-sigma of the odometer speed scale"}
    )
    yaw_scale_sigma: float = field(
        default=0.05,
        metadata={"help": "initial 1-sigma of the yaw-rate scale (x4 after the search)"},
    )
    yaw_bias_sigma_radps: float = field(
        default=0.05, metadata={"help": "initial 1-sigma of the yaw-rate bias (rad/s)"}
    )
    scale_psd: float = field(
        default=1e-6, metadata={"help": "random-walk PSD of the two scales (1/s)"}
    )
    bias_psd: float = field(
        default=1e-6, metadata={"help": "random-walk PSD of the yaw-rate bias (rad^2/s^3)"}
    )
    range_bias_sigma_m: float = field(
        default=0.2,
        metadata={
            "help": "initial 1-sigma of a range bias common to all anchors (antenna "
            "delay), a state; 0: no bias"
        },
    )
    position_psd: float = field(
        default=1e-5,
        metadata={"help": "position random walk per axis (m^2/s): slip, antenna sway"},
    )
    robust: bool = field(default=True, metadata={"help": "IGG-III factor on the ranges"})
    k0: float = field(default=3.0, metadata={"help": "IGG-III k0"})
    k1: float = field(default=4.0, metadata={"help": "IGG-III k1"})
    range_sigma_m: float = field(
        default=0.15,
        metadata={"help": "range 1-sigma (m) for rows without one when session.toml has none"},
    )
    tag_up_m: float = field(
        default=0.0, metadata={"help": "antenna height (m) of a platform without navigation"}
    )

    def __post_init__(self) -> None:
        if min(self.speed_sigma_mps, self.yaw_rate_sigma_radps, self.range_sigma_scale) < 0:
            raise ValueError(
                "speed_sigma_mps, yaw_rate_sigma_radps and range_sigma_scale must be >= 0"
            )
        if not 0 < self.k0 < self.k1:
            raise ValueError(f"k0 = {self.k0}, k1 = {self.k1}: expected 0 < k0 < k1")
        for name in ("calib_distance_m", "speed_scale_sigma", "yaw_scale_sigma", "range_sigma_m"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} = {getattr(self, name)}, expected > 0")
        for name in (
            "yaw_bias_sigma_radps",
            "range_bias_sigma_m",
            "scale_psd",
            "bias_psd",
            "position_psd",
        ):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} = {getattr(self, name)}, expected >= 0")


@dataclass(frozen=True, eq=False)
class OdoTrack:
    """One platform's filter input: steps (odometer and range times) and ranges."""

    platform: str
    t: FloatArray  # (K,) step times
    v: FloatArray  # (K,) speed held over (t_{k-1}, t_k]
    w: FloatArray  # (K,) yaw rate held over (t_{k-1}, t_k]
    ptr: np.ndarray  # (K + 1,) ranges of step k: rows ptr[k]:ptr[k + 1]
    anchor: FloatArray  # (R, 3)
    rng: FloatArray  # (R,)
    var: FloatArray  # (R,)
    up: FloatArray  # (K,)
    interval_s: float  # the odometer's sample interval
    distance: FloatArray  # (K,) odometer distance travelled since t[0]
    init_pos: FloatArray  # (2,)
    init_sigma_m: float
    yaw_source: str
    wheelbase_m: float | None


def _yaw_rate(session: Session, pid: str) -> tuple[FloatArray, str] | None:
    odo = session.odometer[pid]
    if odo.yaw_rate_radps is not None:
        return np.asarray(odo.yaw_rate_radps, dtype=np.float64), f"odometer ({odo.form})"
    imu = session.imu.get(pid)
    if imu is None or len(imu.time_s) < 2:
        return None
    # mean z rate over each odometer interval [T_j, T_j+1) (the interval it is held over)
    gz = imu.gyro_radps[:, 2]
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (gz[1:] + gz[:-1]) * np.diff(imu.time_s))))
    at = np.interp(odo.time_s, imu.time_s, theta)
    w = np.empty(len(odo.time_s))
    w[:-1] = np.diff(at) / np.diff(odo.time_s)
    w[-1] = np.interp(odo.time_s[-1], imu.time_s, gz)
    return w, "IMU z gyro"


def _platform_ranges(
    session: Session, frame: pd.DataFrame, pid: str, anchors: Mapping[str, FloatArray]
) -> pd.DataFrame:
    """The platform's ranges to anchors: time, anchor, range, var (time order)."""
    a_from = frame["from"].isin(list(anchors)).to_numpy()
    a_to = frame["to"].isin(list(anchors)).to_numpy()
    mine_from = (frame["from"] == pid).to_numpy() & a_to
    mine_to = (frame["to"] == pid).to_numpy() & a_from
    sel = mine_from | mine_to
    anchor = np.where(mine_from[sel], frame["to"].to_numpy()[sel], frame["from"].to_numpy()[sel])
    return pd.DataFrame(
        {
            "time": frame["time"].to_numpy()[sel],
            "anchor": anchor,
            "range": frame["range"].to_numpy()[sel],
            "var": frame["var"].to_numpy()[sel],
        }
    )


def _initial_fix(
    session: Session, ranges: pd.DataFrame, rows: pd.DataFrame, pid: str, params: OdoUwbParams
) -> tuple[FloatArray, float, float] | None:
    """The first robust LSQ fix (east, north), its time and 1-sigma (m), or None."""
    need = min(rows["anchor"].nunique(), 4)
    if need < 3:
        return None
    seen: set[str] = set()
    t = rows["time"].to_numpy()
    span = 0.0
    for k, a in enumerate(rows["anchor"]):
        seen.add(str(a))
        if len(seen) >= need:
            span = float(t[k] - t[0])
            break
    lsq = LsqParams(epoch_merge_s=span + 1e-6, tag_up_m=params.tag_up_m)
    mine = ranges[(ranges["from"] == pid) | (ranges["to"] == pid)]
    fix = lsq_fixes(session, mine, lsq).get(pid)
    if fix is None or len(fix.time_s) == 0:
        return None
    sigma = float(np.sqrt(np.trace(fix.cov[0])))
    return fix.pos[0, :2], float(fix.time_s[0]), sigma + 0.0


def odo_tracks(
    session: Session, ranges: pd.DataFrame, params: OdoUwbParams
) -> tuple[dict[str, OdoTrack], list[str]]:
    """The filter input of every platform with an odometer and anchor ranges, and notes
    on the platforms left out."""
    notes: list[str] = []
    anchors = anchor_positions(session)
    if not session.odometer or not anchors:
        return {}, notes
    frame = clean_ranges(session, ranges, range_sigma_default(session, params.range_sigma_m))
    out: dict[str, OdoTrack] = {}
    for pid in sorted(session.odometer):
        odo = session.odometer[pid]
        if pid not in session.platforms or session.platforms[pid].role == "anchor":
            continue
        yaw = _yaw_rate(session, pid)
        if yaw is None:
            notes.append(
                f"odo_uwb: {pid} not positioned: its odometer gives speed only and it has no "
                "IMU (the filter needs a yaw rate: wheel speeds + wheelbase, a twist, or an IMU)"
            )
            continue
        rows = _platform_ranges(session, frame, pid, anchors)
        t_odo = odo.time_s
        rows = rows[(rows["time"] >= t_odo[0]) & (rows["time"] <= t_odo[-1])]
        fix = _initial_fix(session, ranges, rows, pid, params) if len(rows) else None
        if fix is None:
            notes.append(f"odo_uwb: {pid} not positioned: no least-squares fix from its anchors")
            continue
        steps = np.unique(np.concatenate([t_odo, rows["time"].to_numpy()]))
        held = np.clip(np.searchsorted(t_odo, steps[:-1], side="right") - 1, 0, None)
        v = np.zeros(len(steps))
        w = np.zeros(len(steps))
        v[1:] = odo.speed_mps[held]
        w[1:] = yaw[0][held]
        distance = np.concatenate(([0.0], np.cumsum(np.abs(v[1:]) * np.diff(steps))))
        step_of = np.searchsorted(steps, rows["time"].to_numpy())
        ptr = np.searchsorted(step_of, np.arange(len(steps) + 1), side="left")
        if pid in session.nav and len(session.nav[pid]) > 0:
            nav = session.nav[pid]
            up = np.interp(steps, nav.time_s, nav.enu_m[:, 2])
        else:
            up = np.full(len(steps), params.tag_up_m)
        pos0, t_fix, sigma0 = fix
        moved = float(np.interp(t_fix, steps, distance))
        out[pid] = OdoTrack(
            platform=pid,
            t=steps,
            v=v,
            w=w,
            ptr=ptr.astype(np.int64),
            anchor=np.stack([anchors[a] for a in rows["anchor"]]),
            rng=rows["range"].to_numpy(dtype=np.float64),
            var=rows["var"].to_numpy(dtype=np.float64),
            up=up,
            interval_s=odo.interval_s,
            distance=distance,
            init_pos=np.asarray(pos0, dtype=np.float64),
            init_sigma_m=max(sigma0, 0.1) + moved,
            yaw_source=yaw[1],
            wheelbase_m=odo.wheelbase_m,
        )
    return out, notes


def head_of(track: OdoTrack, n_steps: int) -> OdoTrack:
    """The track's first ``n_steps`` steps."""
    end = int(track.ptr[n_steps])
    return dataclasses.replace(
        track,
        t=track.t[:n_steps],
        v=track.v[:n_steps],
        w=track.w[:n_steps],
        ptr=track.ptr[: n_steps + 1],
        anchor=track.anchor[:end],
        rng=track.rng[:end],
        var=track.var[:end],
        up=track.up[:n_steps],
        distance=track.distance[:n_steps],
    )
