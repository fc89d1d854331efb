"""Position methods from raw GPS observations (issue 13 items 4-5; docs/methods-gnss.md):

- ``tight``: the tightly coupled GPS/UWB robust Kalman filter of paper 002
  (:mod:`coopproc.stages.gnss.tight_filter`): pseudorange, Doppler, UWB ranges to
  anchors and to the other platforms, IGG-III on every innovation;
- ``tight_kf``: the same with the standard Kalman filter (paper 002 Tables 6-7's "KF");
- ``gnss``: the same robust filter without UWB (GPS only: Tables 3-5's GPS rows);
- ``gnss_kf``: GPS only, standard Kalman filter.

They run on the observed ranges only, for every platform with ``obs_<ID>.*``
(``Session.gnss``); a platform that also has IMU samples runs paper 002's INS error
states (:mod:`coopproc.stages.gnss.tight_ins`; ``[gnss] ins``), with a note. Paper
002's experiments are ``[gnss]`` settings: satellites kept per epoch
(``max_satellites``, windows ``[[gnss.mask]]``) and pseudorange gross errors
(``[[gnss.gross]]``); UWB gross errors come from ``coopproc inject --gross``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.gnss.tight import GnssEpochs, local_frame, prepare
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.base import NavStates, PositionInput, PositionProduct, PositionStage
from coopproc.stages.gnss.tight_dop import dop_note, dop_table
from coopproc.stages.gnss.tight_filter import (
    RangeRows,
    TightOptions,
    TrackOutput,
    run_tight,
)
from coopproc.stages.gnss.tight_ins import track_factory
from coopproc.stages.shared.data import anchor_positions, range_sigma_default

__all__ = ["GNSS_METHODS", "GNSS_STAGES", "GnssParams", "GrossError", "MaskWindow"]

#: The methods, GPS-only first.
GNSS_METHODS: tuple[str, ...] = ("gnss", "gnss_kf", "tight", "tight_kf")


@dataclass(frozen=True)
class MaskWindow:
    """Satellites kept in [t0, t1] (paper 002 scenario 5)."""

    t0: float = field(default=0.0, metadata={"help": "start, session time (s)"})
    t1: float = field(default=0.0, metadata={"help": "end, session time (s)"})
    keep: int = field(default=4, metadata={"help": "satellites kept (highest elevations)"})


@dataclass(frozen=True)
class GrossError:
    """A gross error on one pseudorange (paper 002 scenario 6, Table 6)."""

    t: float = field(default=0.0, metadata={"help": "epoch, session time (s; nearest epoch)"})
    prn: int = field(default=0, metadata={"help": "GPS satellite number"})
    meters: float = field(default=20.0, metadata={"help": "metres added to its pseudorange"})
    platform: str = field(default="", metadata={"help": "platform id; empty: every platform"})


@dataclass(frozen=True)
class GnssParams:
    """The GPS position methods (run config ``[gnss]``)."""

    methods: tuple[str, ...] = field(
        default=("gnss", "tight"),
        metadata={
            "help": "methods added to [pipeline] positions when platforms have obs_<ID> "
            "files and the chain names none (gnss, gnss_kf, tight, tight_kf); [] = off"
        },
    )
    k0: float = field(default=3.0, metadata={"help": "IGG-III k0 (paper 002: 2.5..3.5)"})
    k1: float = field(default=4.5, metadata={"help": "IGG-III k1 (paper 002: 3.5..4.5)"})
    elevation_mask_deg: float = field(default=10.0, metadata={"help": "elevation mask, deg"})
    accel_psd: float = field(
        default=0.5, metadata={"help": "horizontal white-acceleration PSD, m^2/s^3"}
    )
    accel_psd_up: float = field(
        default=0.05, metadata={"help": "vertical white-acceleration PSD, m^2/s^3"}
    )
    doppler_sigma_mps: float = field(
        default=0.1, metadata={"help": "range-rate (Doppler) 1-sigma, m/s"}
    )
    range_sigma_m: float = field(
        default=0.15,
        metadata={"help": "UWB range 1-sigma (m) for rows without one when session.toml has none"},
    )
    max_satellites: int = field(
        default=0, metadata={"help": "satellites kept per epoch (highest); 0 = all"}
    )
    mask: tuple[MaskWindow, ...] = field(
        default=(), metadata={"help": "windows with fewer satellites: [[gnss.mask]] t0, t1, keep"}
    )
    gross: tuple[GrossError, ...] = field(
        default=(),
        metadata={"help": "pseudorange gross errors: [[gnss.gross]] t, prn, meters, platform"},
    )
    ins: bool = field(
        default=True,
        metadata={
            "help": "platforms with an IMU run paper 002's INS error states (false: the "
            "constant-velocity model, as platforms without an IMU)"
        },
    )

    def __post_init__(self) -> None:
        bad = [m for m in self.methods if m not in GNSS_METHODS]
        if bad:
            raise ValueError(f"unknown method {bad[0]}; expected {', '.join(GNSS_METHODS)}")
        if not 0.0 < self.k0 < self.k1:
            raise ValueError(f"need 0 < k0 < k1, found k0 = {self.k0}, k1 = {self.k1}")
        if self.max_satellites < 0 or any(w.keep < 0 or w.t1 <= w.t0 for w in self.mask):
            raise ValueError("max_satellites and mask keep must be >= 0, mask t1 > t0")


def gnss_platforms(session: Session) -> tuple[str, ...]:
    """Platforms with GPS observations (that are not anchors)."""
    return tuple(
        p
        for p in sorted(session.gnss)
        if p in session.platforms and session.platforms[p].role != "anchor"
    )


def _check(session: Session) -> None:
    if not gnss_platforms(session):
        raise StageError(
            "gnss/tight: no platform has GPS observations; expected obs_<ID>.rnx (or "
            ".<yy>o) and a navigation file in the session"
        )


def _keep_fn(params: GnssParams):  # type: ignore[no-untyped-def]
    windows = params.mask
    base = params.max_satellites or None

    def keep(t: float) -> int | None:
        n = base
        for w in windows:
            if w.t0 <= t <= w.t1:
                n = w.keep if n is None else min(n, w.keep)
        return n

    return keep


def _gross_map(
    params: GnssParams, epochs: dict[str, GnssEpochs]
) -> dict[tuple[str, int], dict[int, float]]:
    out: dict[tuple[str, int], dict[int, float]] = {}
    for g in params.gross:
        for p, ep in epochs.items():
            if (g.platform and g.platform != p) or not len(ep):
                continue
            k = int(np.argmin(np.abs(ep.time_s - g.t)))
            if abs(float(ep.time_s[k]) - g.t) <= 0.5:
                cell = out.setdefault((p, k), {})
                cell[g.prn] = cell.get(g.prn, 0.0) + g.meters
    return out


def _range_rows(session: Session, frame: pd.DataFrame, fallback: float) -> RangeRows:
    f = frame[np.isfinite(frame["range"].to_numpy(np.float64))]
    f = f.sort_values("time", kind="stable")
    sigma = f["sigma"].to_numpy(np.float64)
    sigma = np.where(
        np.isfinite(sigma) & (sigma > 0), sigma, range_sigma_default(session, fallback)
    )
    return RangeRows(
        f["time"].to_numpy(np.float64),
        tuple(f["from"].astype(str)),
        tuple(f["to"].astype(str)),
        f["range"].to_numpy(np.float64),
        sigma,
    )


def _fixed(session: Session):  # type: ignore[no-untyped-def]
    anchors = anchor_positions(session)

    def where(pid: str, t: float) -> tuple[FloatArray, FloatArray] | None:
        if pid in anchors:
            return anchors[pid], np.zeros((3, 3))
        nav = session.nav.get(pid)
        if nav is None or len(nav) < 2 or not nav.time_s[0] <= t <= nav.time_s[-1]:
            return None
        pos = nav.interpolate(np.array([t]))[0]
        sig = np.array([0.1, 0.1, 0.1])
        if nav.sigma_enu_m is not None:
            k = int(np.clip(np.searchsorted(nav.time_s, t), 0, len(nav) - 1))
            sig = np.nan_to_num(nav.sigma_enu_m[k], nan=0.1)
        return pos, np.diag(sig**2)

    return where


def _start(session: Session, pid: str, t0: float) -> FloatArray:
    nav = session.nav.get(pid)
    if nav is not None and len(nav):
        k = int(np.clip(np.searchsorted(nav.time_s, t0), 0, len(nav) - 1))
        return np.asarray(nav.enu_m[k], dtype=np.float64).copy()
    return np.zeros(3)


def _trajectories(
    session: Session, outputs: dict[str, TrackOutput], output: str
) -> tuple[dict[str, Trajectory], dict[str, NavStates]]:
    positions: dict[str, Trajectory] = {}
    states: dict[str, NavStates] = {}
    for pid, out in sorted(outputs.items()):
        if not out.time_s:
            continue
        t = np.asarray(out.time_s)
        x = np.asarray(out.state)
        s = np.asarray(out.sigma)
        att = np.asarray(out.att_deg) if out.att_deg else None  # the INS's
        if output == "nav" and pid in session.nav:
            tn = session.nav[pid].time_s
            tn = tn[(tn >= t[0]) & (tn <= t[-1])]
            x = np.column_stack([np.interp(tn, t, x[:, i]) for i in range(6)])
            s = np.column_stack([np.interp(tn, t, s[:, i]) for i in range(6)])
            if att is not None:
                att[:, 2] = np.degrees(np.unwrap(np.radians(att[:, 2])))
                att = np.column_stack([np.interp(tn, t, att[:, i]) for i in range(3)])
                att[:, 2] = np.mod(att[:, 2], 360.0)
            t = tn
        positions[pid] = Trajectory(pid, t, x[:, :3].copy(), s[:, :3].copy())
        nan3 = np.full((t.size, 3), np.nan)
        att = nan3.copy() if att is None else att
        states[pid] = NavStates(t, x[:, 3:6].copy(), att, s[:, 3:6].copy(), nan3)
    return positions, states


def solve(
    session: Session,
    ranges: pd.DataFrame,
    params: GnssParams,
    uwb: bool,
    robust: bool,
    with_dop: bool = False,
    notes: list[str] | None = None,
) -> tuple[dict[str, TrackOutput], pd.DataFrame | None]:
    """The filter's outputs per platform (see the module docstring) and, ``with_dop``,
    the DOP table of :func:`coopproc.stages.gnss.tight_dop.dop_table`; ``notes`` gets
    one line per platform with an IMU (``params.ins``)."""
    ids = gnss_platforms(session)
    epochs = {p: prepare(session.gnss[p]) for p in ids}
    starts = {
        p: _start(session, p, float(ep.time_s[0]) if len(ep) else 0.0) for p, ep in epochs.items()
    }
    keep = _keep_fn(params)
    opt = TightOptions(
        uwb=uwb,
        robust=robust,
        k0=params.k0,
        k1=params.k1,
        mask_deg=params.elevation_mask_deg,
        q_h=params.accel_psd,
        q_v=params.accel_psd_up,
        doppler_sigma_mps=params.doppler_sigma_mps,
        keep=keep,
        gross=_gross_map(params, epochs),
    )
    rows = _range_rows(session, ranges, params.range_sigma_m)
    frame = local_frame(session.origin_llh)
    fixed = _fixed(session)
    if params.ins and any(p in session.imu for p in ids):
        make = track_factory(session, frame, ranges, [] if notes is None else notes)
        outputs = run_tight(epochs, starts, frame, rows, fixed, opt, make)
    else:
        outputs = run_tight(epochs, starts, frame, rows, fixed, opt)
    if not with_dop:
        return outputs, None
    dop = dop_table(epochs, outputs, frame, rows, fixed, keep, params.elevation_mask_deg)
    return outputs, dop


def _runner(name: str, uwb: bool, robust: bool):  # type: ignore[no-untyped-def]
    def run(inp: PositionInput, params: GnssParams) -> PositionProduct:
        ins: list[str] = []
        outputs, dop = solve(inp.session, inp.ranges, params, uwb, robust, name == "tight", ins)
        positions, states = _trajectories(inp.session, outputs, inp.output)
        notes = [f"{name}: {line}" for line in ins]
        notes += dop_note(name, dop) if dop is not None else []
        return PositionProduct(positions=positions, states=states, notes=tuple(notes))

    return run


def _stage(name: str, uwb: bool, robust: bool, what: str) -> PositionStage:
    return PositionStage(
        name=name,
        params_type=GnssParams,
        section="gnss",
        run=_runner(name, uwb, robust),
        help=what,
        check=_check,
        uwb_only=True,
        requires=frozenset({"gnss"}),
        observed_only=True,
    )


GNSS_STAGES: tuple[PositionStage, ...] = (
    _stage("gnss", False, True, "GPS pseudorange + Doppler robust KF (paper 002, GPS only)"),
    _stage("gnss_kf", False, False, "GPS pseudorange + Doppler standard KF"),
    _stage("tight", True, True, "tightly coupled GPS/UWB robust KF (paper 002)"),
    _stage("tight_kf", True, False, "tightly coupled GPS/UWB standard KF (paper 002)"),
)
