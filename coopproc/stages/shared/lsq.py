"""Robust least-squares UWB positioning of tags from fixed anchors (paper 003 sec. 2.2).

Every (tag, epoch) with ranges to enough anchors is one small Gauss-Newton problem; all
of them are solved together, vectorized over epochs (padded arrays, batched 2x2 / 3x3
solves), so a day of 1 Hz data takes seconds.

Model (paper 003 eq. (6)-(11), the formulas are missing from the text and rebuilt from
it): r_s = |X_tag - X_s| + e, linearized at the current estimate (Taylor expansion),
solved by weighted least squares dX = (A^T P A)^-1 A^T P l and iterated. The robust
weight (eq. (12), "ranging noise and residual-based", c = 1.3-2.0) is read as the Huber
/ IGG-I form on the standardized residual v~_k = v_k / sigma_{v_k}:

    p_k = 1 / sigma_k^2                    if |v~_k| <= c
    p_k = (1 / sigma_k^2) * c / |v~_k|     if |v~_k| >  c

with sigma_{v_k}^2 = sigma_k^2 - a_k N^-1 a_k^T (the residual variance, a-priori unit
weight 1 since the weights are in 1/m^2), iterated to convergence starting from plain LS.

Velocity (paper 003 eq. (7)): the range rate of each tag-anchor pair between adjacent
epochs, (r_k - r_{k-1}) / dt, equals u_s . v_tag with u_s the unit vector from the anchor
to the tag's fix at epoch k; solved by least squares with the position's robust weights
and the rate variance 2 sigma^2 / dt^2. The rate is the mean over (t_{k-1}, t_k], so the
velocity lags by half an epoch.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from coopproc.estimation.range_model import slant_ranges_units
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.shared.data import (
    anchor_positions,
    clean_ranges,
    epoch_groups,
    range_sigma_default,
)

__all__ = ["LsqFixes", "LsqParams", "fixes_trajectory", "lsq_fixes", "robust_lsq_positions"]


@dataclass(frozen=True)
class LsqParams:
    """Robust least-squares positioning from anchors (run config ``[fusion.lsq]``)."""

    robust: bool = field(
        default=True, metadata={"help": "residual-based robust weights (paper 003 eq. (12))"}
    )
    c: float = field(
        default=1.5,
        metadata={"help": "robust weight threshold on the standardized residual, 1.3..2.0"},
    )
    dims: int = field(
        default=2,
        metadata={"help": "2: east/north (height from nav, else 0); 3: east/north/up"},
    )
    min_anchors: int = field(
        default=0,
        metadata={"help": "anchors needed for a fix; 0: dims + 1 (one redundant range)"},
    )
    iterations: int = field(default=20, metadata={"help": "Gauss-Newton / reweighting steps"})
    range_sigma_m: float = field(
        default=0.15,
        metadata={"help": "range 1-sigma (m) for rows without one when session.toml has none"},
    )
    epoch_merge_s: float = field(
        default=0.25,
        metadata={
            "help": "ranges up to this (s) after an epoch's first range join it (one ranging "
            "round to all anchors); the tag's own DR carries its motion to each range time"
        },
    )
    rate_max_gap_s: float = field(
        default=2.0, metadata={"help": "longest gap (s) between ranges used as a range rate"}
    )

    tag_up_m: float | None = field(
        default=None,
        metadata={
            "help": "2D: the antenna height (m, up) of a platform without navigation "
            "(a tag) and without a session.toml height; absent: estimated (lsq*), 0 m "
            "(the fusion's start fix)"
        },
    )
    # the constant-velocity Kalman filter and RTS smoother over the fixes (methods
    # lsq_kf, lsq_rts; coopproc.stages.anchors.uwb_kf)
    kf_accel_psd: float = field(
        default=0.05,
        metadata={
            "help": "lsq_kf/lsq_rts: white-acceleration PSD q (m^2/s^3) per axis of the "
            "constant-velocity model"
        },
    )
    kf_velocity: bool = field(
        default=False,
        metadata={"help": "lsq_kf/lsq_rts: also use the range-rate velocities as observations"},
    )
    kf_robust: bool = field(
        default=True, metadata={"help": "lsq_kf/lsq_rts: IGG-III factor on the innovations"}
    )
    kf_k0: float = field(default=3.0, metadata={"help": "lsq_kf/lsq_rts: IGG-III k0"})
    kf_k1: float = field(default=4.0, metadata={"help": "lsq_kf/lsq_rts: IGG-III k1"})
    range_accel_psd: float = field(
        default=0.1,
        metadata={
            "help": "range_kf/range_rts: white-acceleration PSD (m^2/s^3) per axis "
            "(miluv1: 0.1 -> 0.23 m, 0.5 -> 0.28 m)"
        },
    )
    round_max_s: float = field(
        default=1.5,
        metadata={
            "help": "lsq*: longest ranging round (s; a round closes earlier at a repeated "
            "anchor): tuc polls 4 modules in 0.38 s, miluv1 6 anchors in 1.3 s"
        },
    )
    # the geometry tests of the lsq* methods' fixes (coopproc.stages.anchors.anchor_lsq)
    hdop_max: float = field(
        default=50.0,
        metadata={"help": "lsq*: a fix with a larger HDOP is dropped (hanyang_los: 29 at 50 m)"},
    )
    hdop_max_minimal: float = field(
        default=15.0,
        metadata={
            "help": "lsq*: the HDOP bound of a fix with one redundant range (its residual "
            "test has no power against a wrong branch; hanyang_los 3-anchor epochs)"
        },
    )
    residual_alpha: float = field(
        default=0.001,
        metadata={"help": "lsq*: false-alarm rate of the chi-square test on a fix's residuals"},
    )
    mirror_window_s: float = field(
        default=5.0,
        metadata={
            "help": "lsq*: a fix with a mirror solution takes the one nearer the unambiguous "
            "fixes up to this far (s) in time; none: it is dropped"
        },
    )

    def __post_init__(self) -> None:
        if self.kf_accel_psd <= 0 or self.range_accel_psd <= 0:
            raise ValueError("kf_accel_psd and range_accel_psd must be > 0")
        if not 0 < self.kf_k0 < self.kf_k1:
            raise ValueError(f"kf_k0 = {self.kf_k0}, kf_k1 = {self.kf_k1}: expected 0 < k0 < k1")
        if not 1.3 <= self.c <= 2.0:
            raise ValueError(f"c = {self.c} is outside 1.3..2.0 (paper 003 section 2.2)")
        if self.dims not in (2, 3):
            raise ValueError(f"dims = {self.dims}, expected 2 or 3")
        if self.iterations < 1:
            raise ValueError(f"iterations = {self.iterations}, expected at least 1")
        if self.range_sigma_m <= 0:
            raise ValueError(f"range_sigma_m = {self.range_sigma_m}, expected > 0")
        if (
            min(self.hdop_max, self.hdop_max_minimal, self.mirror_window_s) <= 0
            or self.round_max_s < 0
        ):
            raise ValueError("hdop_max, mirror_window_s must be > 0, round_max_s >= 0")
        if not 0 < self.residual_alpha < 1:
            raise ValueError(f"residual_alpha = {self.residual_alpha}, expected in (0, 1)")
        if self.epoch_merge_s < 0 or self.rate_max_gap_s <= 0:
            raise ValueError("epoch_merge_s must be >= 0 and rate_max_gap_s > 0")


def _has_nav(session: Session, tid: str) -> bool:
    return tid in session.nav and len(session.nav[tid]) > 0


def _solve(n_mat: FloatArray, b: FloatArray) -> FloatArray:
    """Batched solve of (E, d, d) systems; singular ones give NaN."""
    det = np.linalg.det(n_mat)
    ok = np.abs(det) > 1e-12 * np.maximum(np.einsum("eii->e", n_mat) ** n_mat.shape[1], 1e-300)
    out = np.full(b.shape, np.nan)
    if ok.any():
        out[ok] = np.linalg.solve(n_mat[ok], b[ok][..., None])[..., 0]
    return out


@dataclass(frozen=True, eq=False)
class LsqFixes:
    """One tag's least-squares fixes with their covariances (``dims`` = d axes)."""

    time_s: FloatArray  # (E,)
    pos: FloatArray  # (E, d) east, north[, up]
    cov: FloatArray  # (E, d, d) N^-1 of the robust fix
    vel: FloatArray  # (E, d) from range rates, NaN where fewer than d rates
    vel_cov: FloatArray  # (E, d, d) its covariance (NaN where vel is NaN)
    up: FloatArray  # (E,) the height used by the 2D model (0 without nav)


def lsq_fixes(session: Session, ranges: pd.DataFrame, params: LsqParams) -> Mapping[str, LsqFixes]:
    """The fixes of :func:`robust_lsq_positions` with full covariances, by tag id."""
    dim = params.dims
    anchors = anchor_positions(session)
    rows = clean_ranges(session, ranges, range_sigma_default(session, params.range_sigma_m))
    is_a_from = rows["from"].isin(list(anchors)).to_numpy()
    is_a_to = rows["to"].isin(list(anchors)).to_numpy()
    keep = is_a_from ^ is_a_to
    rows = rows[keep]
    if rows.empty:
        return {}
    from_is_anchor = is_a_from[keep]
    tag = np.where(from_is_anchor, rows["to"].to_numpy(), rows["from"].to_numpy())
    anchor = np.where(from_is_anchor, rows["from"].to_numpy(), rows["to"].to_numpy())
    time_s = rows["time"].to_numpy()
    epochs, ep_idx = epoch_groups(time_s, params.epoch_merge_s)
    table = pd.DataFrame(
        {"tag": tag, "anchor": anchor, "epoch": ep_idx, "range": rows["range"].to_numpy()}
    )
    table["var"] = rows["var"].to_numpy()
    table["time"] = time_s
    # one row per (tag, epoch, anchor): the last range wins when an epoch has two
    table = table.drop_duplicates(["tag", "epoch", "anchor"], keep="last")
    table = table.sort_values(["tag", "epoch", "anchor"], kind="stable").reset_index(drop=True)
    # range rate from the same tag-anchor pair at the previous epoch (eq. (7))
    grp = table.groupby(["tag", "anchor"], sort=False)
    dt = table["time"] - grp["time"].shift(1)
    rate = (table["range"] - grp["range"].shift(1)) / dt
    ok_rate = (dt > 0) & (dt <= params.rate_max_gap_s)
    table["rate"] = rate.where(ok_rate)
    table["rate_var"] = (2.0 * table["var"] / dt**2).where(ok_rate)
    # padded problems: one per (tag, epoch)
    problem = table.groupby(["tag", "epoch"], sort=False).ngroup().to_numpy()
    slot = table.groupby(["tag", "epoch"], sort=False).cumcount().to_numpy()
    n_prob = int(problem.max()) + 1
    width = int(slot.max()) + 1
    anchor_xyz = np.stack([anchors[a] for a in table["anchor"]])
    row_t = table["time"].to_numpy()
    ep_t = epochs[table["epoch"].to_numpy()]
    tags = table["tag"].to_numpy()
    for tid in np.unique(tags):
        sel = (tags == tid) & (row_t != ep_t)
        if sel.any() and tid in session.nav and len(session.nav[tid]) > 1:
            # |X(t_row) - anchor| = |X(t_epoch) + m - anchor| = |X(t_epoch) - (anchor - m)|
            nav = session.nav[tid]
            motion = nav.interpolate(row_t[sel]) - nav.interpolate(ep_t[sel])
            anchor_xyz[sel] -= np.nan_to_num(motion)
    pos = np.zeros((n_prob, width, 3))
    rng = np.zeros((n_prob, width))
    var = np.ones((n_prob, width))
    rate_arr = np.zeros((n_prob, width))
    rate_var = np.ones((n_prob, width))
    has = np.zeros((n_prob, width), dtype=bool)
    pos[problem, slot] = anchor_xyz
    rng[problem, slot] = table["range"].to_numpy()
    var[problem, slot] = table["var"].to_numpy()
    r_ok = table["rate"].notna().to_numpy()
    rate_arr[problem, slot] = table["rate"].fillna(0.0).to_numpy()
    rate_var[problem, slot] = table["rate_var"].fillna(1.0).to_numpy()
    has_rate = np.zeros((n_prob, width), dtype=bool)
    has[problem, slot] = True
    has_rate[problem, slot] = r_ok
    first = np.unique(problem, return_index=True)[1]
    prob_tag = table["tag"].to_numpy()[first]
    prob_time = epochs[table["epoch"].to_numpy()[first]]
    min_anchors = params.min_anchors or dim + 1
    enough = has.sum(axis=1) >= min_anchors
    # tag height for the 2D model: from its own navigation, else tag_up_m
    tag_up = np.zeros(n_prob)
    no_nav = np.array([not _has_nav(session, t) for t in prob_tag], dtype=bool)
    if dim == 2:
        tag_up[no_nav] = 0.0 if params.tag_up_m is None else params.tag_up_m
        for tid in np.unique(prob_tag[~no_nav]):
            sel = prob_tag == tid
            nav = session.nav[tid]
            tag_up[sel] = np.interp(prob_time[sel], nav.time_s, nav.enu_m[:, 2])
    x, cov, weight = _gauss_newton(pos, rng, var, has, tag_up, params)
    vel, vel_cov = _velocity(x, pos, tag_up, rate_arr, rate_var, has_rate, weight, dim)
    # a tag without navigation: its range-rate velocity carries it to each range time of
    # the epoch (as the nav does above for the others), then the fix is solved again
    lag = row_t - ep_t
    move = no_nav[problem] & (lag != 0) & np.isfinite(vel[problem]).all(axis=1)
    if move.any():
        pos[problem[move], slot[move], :dim] -= vel[problem[move]] * lag[move, None]
        x, cov, weight = _gauss_newton(pos, rng, var, has, tag_up, params)
        vel, vel_cov = _velocity(x, pos, tag_up, rate_arr, rate_var, has_rate, weight, dim)
    out: dict[str, LsqFixes] = {}
    good = enough & np.isfinite(x).all(axis=1)
    for tid in sorted(np.unique(prob_tag[good])):
        sel = good & (prob_tag == tid)
        out[str(tid)] = LsqFixes(
            time_s=prob_time[sel],
            pos=x[sel],
            cov=cov[sel],
            vel=vel[sel],
            vel_cov=vel_cov[sel],
            up=tag_up[sel],
        )
    return out


def robust_lsq_positions(
    session: Session, ranges: pd.DataFrame, params: LsqParams | None = None
) -> Mapping[str, Trajectory]:
    """Positions (and velocities) of every tag ranging to anchors, epoch by epoch.

    Parameters
    ----------
    session : the session (anchors are platforms with role ``anchor``).
    ranges : columns time, from, to, range[, sigma]; rows between a moving platform and
        an anchor are used, others ignored.
    params : LsqParams; ``robust=False`` gives plain weighted least squares.

    Returns
    -------
    tag id -> Trajectory at the epochs with at least ``min_anchors`` anchors, with
    ``sigma_enu_m`` from the estimate's covariance and ``vel_enu_mps`` from range rates
    (NaN where fewer than ``dims`` rates are available). Tags without any fix are absent.
    """
    params = params or LsqParams()
    return {
        tid: fixes_trajectory(tid, fix, params.robust)
        for tid, fix in lsq_fixes(session, ranges, params).items()
    }


def fixes_trajectory(tid: str, fix: LsqFixes, robust: bool = True) -> Trajectory:
    """One platform's fixes as a Trajectory (2D fixes: up from ``fix.up``)."""
    dim = fix.pos.shape[1]
    enu = np.zeros((fix.time_s.shape[0], 3))
    enu[:, :dim] = fix.pos
    sig = np.full_like(enu, np.nan)
    sig[:, :dim] = np.sqrt(np.einsum("eii->ei", fix.cov))
    v3 = np.zeros_like(enu)
    v3[:, :dim] = fix.vel
    v3[np.isnan(v3[:, 0]), 2] = np.nan
    if dim == 2:
        enu[:, 2] = fix.up
    return Trajectory(
        platform=tid,
        time_s=fix.time_s,
        enu_m=enu,
        sigma_enu_m=sig,
        vel_enu_mps=v3,
        source="robust LSQ from anchors" if robust else "LSQ from anchors",
    )


def _design(
    x: FloatArray, pos: FloatArray, tag_up: FloatArray, dim: int
) -> tuple[FloatArray, FloatArray]:
    """Distances (E, m) and unit vectors (E, m, dim) from the anchors to the tag at x."""
    diff = x[:, None, :] - pos[:, :, :dim]
    if dim == 3:
        return slant_ranges_units(diff)
    # in the plane the known height difference is the third component, not estimated
    up = (tag_up[:, None] - pos[:, :, 2])[..., None]
    rho, unit = slant_ranges_units(np.concatenate((diff, up), axis=-1))
    return rho, unit[..., :dim]


def _gauss_newton(
    pos: FloatArray,
    rng: FloatArray,
    var: FloatArray,
    has: FloatArray,
    tag_up: FloatArray,
    params: LsqParams,
    x0: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Batched (robust) Gauss-Newton from ``x0`` (None: the anchors' centroid); returns
    positions, covariances N^-1, robust weights."""
    dim = params.dims
    count = np.maximum(has.sum(axis=1), 1)
    centroid = (pos[:, :, :dim] * has[..., None]).sum(axis=1) / count[:, None]
    x = centroid if x0 is None else x0.copy()
    p0 = np.where(has, 1.0 / var, 0.0)
    w = np.ones_like(p0)
    eye = np.eye(dim)[None] * 1e-12
    n_mat = np.repeat(np.eye(dim)[None], x.shape[0], axis=0)
    plain_steps = max(params.iterations // 2, 1)
    for it in range(params.iterations):
        rho, a = _design(x, pos, tag_up, dim)
        p = p0 * w
        n_mat = np.einsum("emi,em,emj->eij", a, p, a) + eye
        b = np.einsum("emi,em,em->ei", a, p, rng - rho)
        dx = _solve(n_mat, b)
        x = x + np.nan_to_num(dx)
        if params.robust and it + 1 >= plain_steps:
            rho, a = _design(x, pos, tag_up, dim)
            n_mat = np.einsum("emi,em,emj->eij", a, p0 * w, a) + eye
            n_inv = np.linalg.pinv(n_mat)
            leverage = np.einsum("emi,eij,emj->em", a, n_inv, a)
            q_vv = np.maximum(var - leverage, 0.01 * var)  # residual variance
            v_std = np.abs(rho - rng) / np.sqrt(q_vv)
            w = np.where(v_std <= params.c, 1.0, params.c / np.maximum(v_std, 1e-12))
    rho, a = _design(x, pos, tag_up, dim)
    n_mat = np.einsum("emi,em,emj->eij", a, p0 * w, a) + eye
    return x, np.linalg.pinv(n_mat), w


def _velocity(
    x: FloatArray,
    pos: FloatArray,
    tag_up: FloatArray,
    rate: FloatArray,
    rate_var: FloatArray,
    has_rate: FloatArray,
    weight: FloatArray,
    dim: int,
) -> tuple[FloatArray, FloatArray]:
    """Velocity (E, dim) from range rates, paper 003 eq. (7), and its covariance (E, dim,
    dim); NaN with too few rates."""
    _, a = _design(x, pos, tag_up, dim)
    p = np.where(has_rate, weight / rate_var, 0.0)
    n_mat = np.einsum("emi,em,emj->eij", a, p, a)
    b = np.einsum("emi,em,em->ei", a, p, rate)
    vel = _solve(n_mat, b)
    vel[has_rate.sum(axis=1) < dim] = np.nan
    cov = np.full(n_mat.shape, np.nan)
    ok = np.isfinite(vel).all(axis=1)
    if ok.any():
        cov[ok] = np.linalg.pinv(n_mat[ok])
    return vel, cov
