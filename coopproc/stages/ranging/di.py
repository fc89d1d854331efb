"""Distance increments (paper 000, eq. (1)) and the DI smoothing filter (eq. (4)-(7)).

A distance increment (DI) of a pair at range epoch k is the change of the distance between
the two platforms from range epoch k-1 to k. Two forms are provided:

* :func:`di_literal` is eq. (1) exactly as printed: the difference of the two platforms'
  displacement magnitudes, ``|X1_k - X1_{k-1}| - |X2_k - X2_{k-1}|``. It equals the change
  of the inter-platform distance only when both platforms move along the line joining
  them; for a formation driving side by side it is ~0 while the distance may change, and
  for platforms moving in parallel at different speeds it returns the speed difference
  although the distance barely changes.
* :func:`range_increments` is what eq. (2)/(3) need: ``||X1_k - X2_k|| - ||X1_{k-1} -
  X2_{k-1}||``. This is the DI every stage uses. Measured on the simulator (seed 0, DI
  from the navigation solutions against the true range change, RMS): paper-experiment
  (1 Hz) A-B 0.0104 / A-C 0.0042 / B-C 0.0098 m for this form versus 0.221 / 0.286 /
  0.108 m for the literal eq. (1) (larger than the true DI itself, 0.08-0.12 m RMS);
  paper-table1 (10 Hz) 0.0026 versus 0.0173 m.

The DI smoothing filter (eq. (4)) has state [I, s] (DI and DI deviation): the dead
reckoning (DR) DI enters through the control u_k, the cooperative-positioning (CP) DI is
the observation, and an innovation beyond the gate marks a CP jump that is not used.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numba import njit

from coopproc.estimation.range_model import slant_ranges
from coopproc.model import FloatArray
from coopproc.stages.ranging.calibration import window_slices

__all__ = [
    "DEFAULT_DRIFT_SIGMA_MPS",
    "DISmoothingParams",
    "SmoothedDI",
    "anchored_increments",
    "cp_noise_var",
    "di_literal",
    "di_variance",
    "range_increments",
    "smooth_di",
    "windowed_cp_noise_var",
]

#: Position drift 1-sigma (m/s) by role when session.toml gives none (sigma_k of eq. (7)).
#: Followers dead-reckon with INS/odometer (paper 000: 2.7 deg/h gyro, ~0.5 m/s), leaders
#: are GNSS/INS, anchors do not move.
DEFAULT_DRIFT_SIGMA_MPS: dict[str, float] = {"follower": 0.02, "leader": 0.005, "anchor": 0.0}

#: Smallest variance (m^2) of a DI: two ranges at the same time give dt = 0 and eq. (7) 0.
MIN_DI_VAR_M2 = 1e-8


@dataclass(frozen=True)
class DISmoothingParams:
    """Parameters of the DI smoothing filter, TOML table ``[ranging.di]``."""

    dr_base: Literal["cp", "nav"] = field(
        default="cp",
        metadata={
            "help": "cp: DR DI = DR displacements applied from the cooperative positions "
            "(paper 000 fig. 1 closed loop); nav: eq. (2) on the nav positions alone"
        },
    )
    dr_states: bool = field(
        default=True,
        metadata={
            "help": "true: DR DI from the followers' navigation corrected by the causal "
            "fusion's DR states (heading and scale; shared/dr_corrected.py; a follower with "
            "one partner keeps its own); false: the navigation as recorded (paper 000)"
        },
    )
    gate_sigma: float = field(
        default=3.0,
        metadata={
            "help": "CP-DI jump gate: an innovation beyond gate_sigma * sqrt(S) is not used "
            "(paper 000 sec. 3.1.3)"
        },
    )
    cp_sigma_scale: float = field(
        default=1.0,
        metadata={
            "help": "lower bound of the CP-DI noise 1-sigma, in eq. (7) sigmas (R_k is the "
            "larger of this and the robust CP-DR spread)"
        },
    )
    drift_follower_mps: float = field(
        default=DEFAULT_DRIFT_SIGMA_MPS["follower"],
        metadata={"help": "drift sigma (m/s) of a follower when session.toml gives none"},
    )
    drift_leader_mps: float = field(
        default=DEFAULT_DRIFT_SIGMA_MPS["leader"],
        metadata={"help": "drift sigma (m/s) of a leader when session.toml gives none"},
    )
    drift_scaling: Literal["linear", "sqrt"] = field(
        default="sqrt",
        metadata={
            "help": "eq. (7) sigma_k over an interval dt: linear = drift * dt; sqrt = drift * "
            "sqrt(dt * 1 s) (same at 1 Hz, larger at higher range rates)"
        },
    )
    mask_nlos_cp: bool = field(
        default=True,
        metadata={
            "help": "second pass without the CP DI of pairs whose platforms are in an NLOS "
            "event (the cooperative solution used those NLOS ranges)"
        },
    )
    cp_guard_before_s: float = field(
        default=1.0, metadata={"help": "CP DI masked from this long before an event, s"}
    )
    cp_guard_after_s: float = field(
        default=15.0, metadata={"help": "... until this long after it, s"}
    )
    fusion_input: Literal["corrected", "distance"] = field(
        default="corrected",
        metadata={
            "help": "what the DI range set's fusion takes: corrected = the observed ranges "
            "less the DI-Based NLOS estimates (the fusion smooths with the dead reckoning "
            "itself); distance = the DI filter's distance, as paper 000 fuses it"
        },
    )
    deviation_rw: float = field(
        default=1e-4,
        metadata={
            "help": "random walk of the DI deviation s (relative-velocity bias), m/s/sqrt(s): "
            "q_s = (deviation_rw * dt)^2 * dt"
        },
    )

    def __post_init__(self) -> None:
        if self.gate_sigma <= 0:
            raise ValueError(f"gate_sigma must be > 0, found {self.gate_sigma}")
        if self.cp_sigma_scale <= 0:
            raise ValueError(f"cp_sigma_scale must be > 0, found {self.cp_sigma_scale}")
        if self.drift_follower_mps < 0 or self.drift_leader_mps < 0:
            raise ValueError("drift_follower_mps and drift_leader_mps must be >= 0")
        if self.cp_guard_before_s < 0 or self.cp_guard_after_s < 0:
            raise ValueError("cp_guard_before_s and cp_guard_after_s must be >= 0")
        if self.deviation_rw < 0:
            raise ValueError(f"deviation_rw must be >= 0, found {self.deviation_rw}")
        if self.fusion_input not in ("corrected", "distance"):
            raise ValueError(
                f"fusion_input = {self.fusion_input!r}, expected 'corrected' or 'distance'"
            )


def di_literal(pos1_m: FloatArray, pos2_m: FloatArray) -> FloatArray:
    """Eq. (1) as printed: ``|X1_k - X1_{k-1}| - |X2_k - X2_{k-1}|`` (m); NaN at k = 0.

    ``pos1_m``, ``pos2_m``: (n, 3) ENU positions (m) of the two platforms at the range epochs.
    """
    # paper 000, eq. (1)
    out = np.full(pos1_m.shape[0], np.nan)
    step1 = np.linalg.norm(np.diff(pos1_m, axis=0), axis=1)
    step2 = np.linalg.norm(np.diff(pos2_m, axis=0), axis=1)
    out[1:] = step1 - step2
    return out


def range_increments(pos1_m: FloatArray, pos2_m: FloatArray) -> FloatArray:
    """Change of the inter-platform distance between range epochs (m); NaN at k = 0.

    ``||X1_k - X2_k|| - ||X1_{k-1} - X2_{k-1}||``: the I_k of paper 000 eq. (2)/(3), which
    eq. (1) approximates (see the module docstring for the measured difference).
    """
    out = np.full(pos1_m.shape[0], np.nan)
    dist = slant_ranges(pos1_m - pos2_m)
    out[1:] = np.diff(dist)
    return out


def anchored_increments(
    base1_m: FloatArray, base2_m: FloatArray, nav1_m: FloatArray, nav2_m: FloatArray
) -> FloatArray:
    """DR DI with the dead-reckoning displacement applied from the corrected positions (m).

    ``||(B1_{k-1} + dX1_k) - (B2_{k-1} + dX2_k)|| - ||B1_{k-1} - B2_{k-1}||`` where B are the
    cooperative (corrected) positions and dX_k = nav_k - nav_{k-1} each platform's own
    dead-reckoning displacement. This is the DR DI of paper 000's closed loop (sec. 3.1.1,
    fig. 1: the processing centre sends the corrected positions back and each platform
    dead-reckons on from them): only the displacement comes from dead reckoning, so the
    accumulated DR position error does not rotate into the DI. NaN at k = 0.
    """
    out = np.full(base1_m.shape[0], np.nan)
    rel_prev = base1_m[:-1] - base2_m[:-1]
    rel_now = rel_prev + np.diff(nav1_m, axis=0) - np.diff(nav2_m, axis=0)
    out[1:] = slant_ranges(rel_now) - slant_ranges(rel_prev)
    return out


def di_variance(
    time_s: FloatArray, drift1_mps: float, drift2_mps: float, scaling: str = "linear"
) -> FloatArray:
    """Eq. (7): sigma_I^2 = sigma_k1^2 + sigma_k2^2, sigma_ki the drift over the interval (m^2).

    ``scaling = "linear"``: sigma_ki = drift_i * dt (a velocity error, as paper 000 reads);
    ``"sqrt"``: sigma_ki = drift_i * sqrt(dt * 1 s) (a random walk: equal at 1 s intervals,
    larger below 1 s, where the position noise of a GNSS/INS leader dominates). dt is the
    interval between consecutive range epochs; NaN at k = 0; floored at
    :data:`MIN_DI_VAR_M2` (several ranges at one epoch give dt = 0).
    """
    # paper 000, eq. (7)
    out = np.full(time_s.shape[0], np.nan)
    dt = np.diff(time_s)
    span = dt * dt if scaling == "linear" else dt
    out[1:] = np.maximum((drift1_mps**2 + drift2_mps**2) * span, MIN_DI_VAR_M2)
    return out


@njit(cache=True)
def _smooth_kernel(
    time_s: FloatArray,
    di_dr: FloatArray,
    di_cp: FloatArray,
    var_dr: FloatArray,
    var_cp: FloatArray,
    deviation_rw: float,
    gate_sigma: float,
) -> tuple[FloatArray, FloatArray, FloatArray, np.ndarray]:
    n = time_s.shape[0]
    di_out = np.full(n, np.nan)
    var_out = np.full(n, np.nan)
    dev_out = np.full(n, np.nan)
    jump = np.zeros(n, dtype=np.int8)
    s = 0.0
    p_ss = -1.0  # < 0: not initialised yet
    for k in range(1, n):
        u = di_dr[k]
        if not np.isfinite(u):
            continue
        if p_ss < 0.0:
            p_ss = var_dr[k]  # prior: the DR DI bias is within the eq. (7) drift
        dt = time_s[k] - time_s[k - 1]
        # paper 000, eq. (4): u_k = DI_dr_k - I_{k-1}, so I_k^- = I_{k-1} + s_{k-1} + u_k
        # = DI_dr_k + s_{k-1}; I_{k-1} drops out of the prediction and its covariance.
        i_pred = u + s
        p_ii = p_ss + var_dr[k]  # w_I: eq. (7) variance of the DR DI
        p_is = p_ss
        p_ss_pred = p_ss + deviation_rw * deviation_rw * dt * dt * dt
        z = di_cp[k]
        used = False
        if np.isfinite(z):
            v = z - i_pred  # innovation V_k
            s_var = p_ii + var_cp[k]
            if abs(v) <= gate_sigma * np.sqrt(s_var):
                k_i = p_ii / s_var
                k_s = p_is / s_var
                i_new = i_pred + k_i * v
                s = s + k_s * v
                p_ii_new = p_ii - k_i * p_ii
                p_ss = p_ss_pred - k_s * p_is
                p_ii = p_ii_new
                i_pred = i_new
                used = True
            else:
                jump[k] = 1  # CP jump: the state follows DR DI plus the deviation
        if not used:
            p_ss = p_ss_pred
        di_out[k] = i_pred
        var_out[k] = max(p_ii, 1e-8)
        dev_out[k] = s
    return di_out, var_out, dev_out, jump


@dataclass(frozen=True, eq=False)
class SmoothedDI:
    """Output of :func:`smooth_di`, one value per range epoch (NaN at the first)."""

    di_m: FloatArray
    var_m2: FloatArray
    deviation_m: FloatArray
    jump: np.ndarray


def cp_noise_var(di_dr_m: FloatArray, di_cp_m: FloatArray) -> float:
    """Robust variance (m^2) of CP DI - DR DI over the pair: (1.4826 MAD)^2.

    The observation noise R_k of eq. (4) in the spirit of the adaptive estimate of paper
    000 ref. [37]: the CP DI carries the fusion's update corrections, whose size eq. (7)
    does not know; the MAD ignores the large jumps that the gate is there to reject.
    """
    diff = di_cp_m - di_dr_m
    diff = diff[np.isfinite(diff)]
    if diff.shape[0] < 5:
        return 0.0
    mad = float(np.median(np.abs(diff - np.median(diff))))
    return (1.4826 * mad) ** 2


def windowed_cp_noise_var(
    time_s: FloatArray, di_dr_m: FloatArray, di_cp_m: FloatArray, window_s: float
) -> FloatArray:
    """:func:`cp_noise_var` per calibration window (the grid of ranging/local.py: windows
    of ``window_s`` from the first epoch), at every epoch: a stretch of the recording gets
    the same R_k whatever follows it (issue 30)."""
    out = np.zeros(time_s.shape[0])
    if time_s.shape[0] == 0:
        return out
    for lo, hi in window_slices(time_s, window_s):
        out[lo:hi] = cp_noise_var(di_dr_m[lo:hi], di_cp_m[lo:hi])
    return out


def smooth_di(
    time_s: FloatArray,
    di_dr_m: FloatArray,
    di_cp_m: FloatArray,
    var_m2: FloatArray,
    params: DISmoothingParams,
    window_s: float | None = None,
) -> SmoothedDI:
    """Run the DI smoothing filter of paper 000 eq. (4)-(7) over one pair.

    ``var_m2`` is the eq. (7) variance (:func:`di_variance`): the DR-DI process noise w_I;
    the CP-DI observation variance R_k is the larger of ``cp_sigma_scale^2 * var_m2`` and
    :func:`cp_noise_var` (per calibration window of ``window_s`` seconds; None: over the
    pair).
    """
    robust: float | FloatArray = (
        cp_noise_var(di_dr_m, di_cp_m)
        if window_s is None
        else windowed_cp_noise_var(time_s, di_dr_m, di_cp_m, window_s)
    )
    var_cp = np.maximum(var_m2 * params.cp_sigma_scale**2, robust)
    di, var, dev, jump = _smooth_kernel(
        np.ascontiguousarray(time_s, dtype=np.float64),
        np.ascontiguousarray(di_dr_m, dtype=np.float64),
        np.ascontiguousarray(di_cp_m, dtype=np.float64),
        np.ascontiguousarray(var_m2, dtype=np.float64),
        np.ascontiguousarray(var_cp, dtype=np.float64),
        float(params.deviation_rw),
        float(params.gate_sigma),
    )
    return SmoothedDI(di_m=di, var_m2=var, deviation_m=dev, jump=jump)
