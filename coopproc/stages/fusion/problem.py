"""One fusion's filter problem: the prepared inputs (:mod:`~coopproc.stages.fusion.inputs`)
with the drift scales' process noise, the DR states' layout, the initial state and the
compiled kernels' typed inputs (:mod:`~coopproc.stages.fusion.kernel_types`), as
:func:`~coopproc.stages.fusion.fuse.fuse` runs its passes on them.

The process noise (paper 000 eq. (7)): a platform's drift sigma (m/s) is the 1-sigma of
its dead-reckoning velocity error, correlated over ``drift_correlation_s`` = tau: an
epoch of dt seconds gets q = 2 sigma^2 tau dt per axis (``drift_correlation_s = 0``: the
plain (sigma dt)^2); a follower with DR states gets its residual position noise instead.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from coopproc.model import FloatArray, Session
from coopproc.stages.fusion.dr_states import DrLayout, dr_layout
from coopproc.stages.fusion.ekf import block_size
from coopproc.stages.fusion.inputs import FusionInputs
from coopproc.stages.fusion.kernel_types import Navigation, Observations, Process, Reads, Slots
from coopproc.stages.fusion.params import FusionParams

__all__ = ["FilterProblem", "filter_problem"]


@dataclass(frozen=True, eq=False)
class FilterProblem:
    """One fusion's filter inputs: the prepared inputs (:class:`FusionInputs`) with the
    drift scales' process noise, the DR states' layout and the kernels' typed inputs."""

    moving: list[str]
    epochs: FloatArray
    ep_idx: np.ndarray
    obs: dict[str, np.ndarray]
    source: np.ndarray
    from_id: pd.api.extensions.ExtensionArray
    to_id: pd.api.extensions.ExtensionArray
    rec_ptr: np.ndarray
    rec_plat: np.ndarray
    x0: FloatArray
    c0: FloatArray
    dr: DrLayout
    dr_rec: np.ndarray  # the epochs the DR states are reported at (none: not reported)
    dr_states: bool
    nav: Navigation
    proc: Process
    kernel_obs: Observations
    slots: Slots
    reads: Reads  # where the followers' pending transitions are applied (deferred.py)
    block: int  # the smoother's checkpoint block (0: no smoother pass)
    record_forward: bool  # the forward pass records its states at the slots


def filter_problem(
    inputs: FusionInputs,
    session: Session,
    params: FusionParams,
    drift_scale: Mapping[str, float] | None,
    dr_states: bool,
    forward: bool,
) -> FilterProblem:
    """The filter's inputs for ``inputs`` with the drift scales: each platform's process
    noise from its drift sigma (fuse's module docstring), the followers' DR states after
    the positions (``estimation/dr_model.py``), the smoother's block; ``dr_states``: the
    DR states are reported; ``forward``: the forward trajectories are built."""
    moving, epochs = inputs.moving, inputs.epochs
    dt = np.diff(epochs, prepend=epochs[0])
    scale = drift_scale or {}
    drift = np.array([_drift(session, p, params) * scale.get(p, 1.0) for p in moving])
    if params.drift_correlation_s > 0:  # 2 sigma^2 tau dt, see the module docstring
        q_coef = 2.0 * drift**2 * params.drift_correlation_s
        q_squared = False
    else:  # (sigma dt)^2
        q_coef = drift.astype(np.float64)
        q_squared = True
    dr = dr_layout(session, moving, epochs, params, scale)
    if dr.active:  # positions first, each follower's DR states after
        n_pos = inputs.x0.shape[0]
        x0 = np.concatenate((inputs.x0, np.zeros(dr.prior.shape[0])))
        c0 = np.zeros((x0.shape[0], x0.shape[0]))
        c0[:n_pos, :n_pos] = inputs.c0
        c0[n_pos:, n_pos:] = np.diag(dr.prior)
        q_coef = np.where(dr.idx >= 0, dr.position_q, q_coef)
        if q_squared:  # the kernel squares every q_coef
            q_coef = np.where(dr.idx >= 0, np.sqrt(dr.position_q), q_coef)
    else:
        x0, c0 = inputs.x0, inputs.c0
    smooth = params.smoother and epochs.shape[0] > 1
    obs = inputs.obs
    return FilterProblem(
        moving, epochs, inputs.ep_idx, obs, inputs.source, inputs.from_id, inputs.to_id,
        inputs.rec_ptr, inputs.rec_plat, x0, c0, dr,
        dr.rec if dr_states else dr.rec[:0], dr_states,
        Navigation(epochs, *inputs.nav),
        Process.of(q_coef, q_squared, dt, dr.idx, dr.q),
        Observations(
            obs["ptr"], obs["kind"], obs["a"], obs["b"], obs["anchor"], obs["anchor_table"],
            obs["dz2"], obs["z"], obs["var"],
        ),
        Slots(inputs.rec_ptr, inputs.rec_plat),
        # every pass of the fusion reads the same (whatever it records): the same bits
        Reads(inputs.rec_ptr, inputs.rec_plat, dr.rec),
        block_size(epochs.shape[0]) if smooth else 0,
        # the forward states are read for the forward trajectories, or as the solution
        # when no smoother pass follows; else the smoother records its own and the forward
        # pass none (memory, issue 11: four floats per slot, ~0.27 GB per fusion at a day)
        forward or not smooth,
    )  # fmt: skip


def _drift(session: Session, pid: str, params: FusionParams) -> float:
    value = session.platforms[pid].drift_sigma_mps
    return float(value) if value is not None and value > 0 else params.drift_sigma_mps
