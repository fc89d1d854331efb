"""Which platforms carry DR states, their priors and noises, and their table.

See :mod:`coopproc.stages.fusion.dr_model` for the model. This module lays the states
out (each follower's three after all the positions), turns ``[fusion]``'s figures into
the kernel's prior variances and per-second random-walk variances, picks the epochs at
which the states are reported, and builds the ``dr_states`` table from the kernels'
output.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import FloatArray, Session
from coopproc.stages.fusion.dr_model import DR_STATES

if TYPE_CHECKING:
    from coopproc.stages.fusion.fuse import FusionParams

__all__ = ["DR_COLUMNS", "DrLayout", "dr_layout", "dr_states_table"]

_DEG = np.pi / 180.0
_DPH = _DEG / 3600.0  # deg/h -> rad/s
_SQRT_H = 60.0  # sqrt(3600 s)

#: The dr_states table's columns (docs/outputs.md, dr_states.csv).
DR_COLUMNS = (
    "time",
    "platform",
    "solution",
    "heading_error_deg",
    "heading_error_sigma_deg",
    "heading_rate_error_dph",
    "heading_rate_error_sigma_dph",
    "scale_error",
    "scale_error_sigma",
)


@dataclass(frozen=True)
class DrLayout:
    """The DR states of one fusion.

    ``idx[p]``: the state index of platform p's heading correction (-1: no DR states);
    ``q[p]``: the heading, heading-rate and scale random walks' variance per second;
    ``prior``: the initial variances of all DR states, in state order; ``position_q[p]``:
    a follower's residual position noise per second (the kernel's ``q_coef``);
    ``rec``: the epochs at which the DR states are reported (ascending).
    """

    idx: NDArray[np.int64]
    q: FloatArray
    prior: FloatArray
    position_q: FloatArray
    rec: NDArray[np.int64]


def _carries_dr(session: Session, pid: str) -> bool:
    """Followers do: their navigation is dead reckoning. Leaders are fixed by their own
    GNSS/INS fix (a position update), tags have no navigation of their own."""
    return session.platforms[pid].role == "follower"


def dr_layout(
    session: Session,
    moving: list[str],
    epochs: FloatArray,
    params: FusionParams,
    drift_scale: Mapping[str, float] | None = None,
) -> DrLayout:
    """The DR layout of ``moving`` (state ``"dr"``; ``"position"``: none).

    ``drift_scale``: the self-calibration's per-platform factor on the DR noise 1-sigmas
    (the heading, heading-rate and scale walks and the residual velocity noise alike).
    """
    n_plat = len(moving)
    dim = params.dims
    idx = np.full(n_plat, -1, dtype=np.int64)
    q = np.zeros((n_plat, DR_STATES))
    position_q = np.zeros(n_plat)
    prior: list[float] = []
    scale = drift_scale or {}
    if params.state == "dr":
        walk = np.array(
            [
                (params.heading_walk_dpsh * _DEG / _SQRT_H) ** 2,
                (params.heading_rate_walk_dphpsh * _DPH / _SQRT_H) ** 2,
                (params.scale_walk_psh / _SQRT_H) ** 2,
            ]
        )
        first = [
            (params.heading_sigma_deg * _DEG) ** 2,
            (params.heading_rate_sigma_dph * _DPH) ** 2,
            params.scale_sigma**2,
        ]
        for p, pid in enumerate(moving):
            if not _carries_dr(session, pid):
                continue
            idx[p] = n_plat * dim + len(prior)
            factor = scale.get(pid, 1.0) ** 2
            q[p] = walk * factor
            position_q[p] = params.dr_position_sigma_mps**2 * factor
            prior.extend(first)
    rec = np.zeros(0, dtype=np.int64)
    if idx.max(initial=-1) >= 0 and epochs.shape[0] > 0:
        bins = np.floor((epochs - epochs[0]) / params.dr_states_every_s)
        rec = np.flatnonzero(np.diff(bins, prepend=-1.0) != 0).astype(np.int64)
    return DrLayout(idx=idx, q=q, prior=np.array(prior), position_q=position_q, rec=rec)


def dr_states_table(
    moving: list[str],
    epochs: FloatArray,
    layout: DrLayout,
    forward: tuple[FloatArray, FloatArray],
    smoothed: tuple[FloatArray, FloatArray],
) -> pd.DataFrame:
    """The DR states as the dead reckoning's errors, per follower and reported epoch.

    The states are corrections (the DR increment times (1 + s) R(theta) is the true one);
    the table gives the DR's own errors: heading error -theta (deg), heading-rate error
    -omega (deg/h, the gyro bias as the heading sees it), scale error -s / (1 + s) (the DR
    increment is (1 + scale_error) times the true one), each with its 1-sigma (the scale's
    to first order).
    """
    n_pos = int(layout.idx[layout.idx >= 0].min()) if (layout.idx >= 0).any() else 0
    times = epochs[layout.rec]
    frames = []
    for label, (values, variances) in (("forward", forward), ("smoothed", smoothed)):
        if values.shape[0] != times.shape[0]:
            continue
        sig = np.sqrt(np.maximum(variances, 0.0))
        for p, pid in enumerate(moving):
            e = int(layout.idx[p]) - n_pos
            if layout.idx[p] < 0:
                continue
            s = values[:, e + 2]
            frames.append(
                pd.DataFrame(
                    {
                        "time": times,
                        "platform": pid,
                        "solution": label,
                        "heading_error_deg": -np.degrees(values[:, e]),
                        "heading_error_sigma_deg": np.degrees(sig[:, e]),
                        "heading_rate_error_dph": -values[:, e + 1] / _DPH,
                        "heading_rate_error_sigma_dph": sig[:, e + 1] / _DPH,
                        "scale_error": -s / (1.0 + s),
                        "scale_error_sigma": sig[:, e + 2] / (1.0 + s) ** 2,
                    }
                )
            )
    if not frames:
        return pd.DataFrame({c: [] for c in DR_COLUMNS})
    return pd.concat(frames, ignore_index=True)[list(DR_COLUMNS)]
