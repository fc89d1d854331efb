"""Which platforms carry DR states, their priors and noises, and their table.

See :mod:`coopproc.estimation.dr_model` for the model. This module lays the states
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

from coopproc.estimation.dr_model import DR_STATES
from coopproc.model import FloatArray, Session
from coopproc.names import DR_STATES_COLUMNS

if TYPE_CHECKING:
    from coopproc.stages.base import PositionProduct
    from coopproc.stages.fusion.params import FusionParams

__all__ = [
    "DrLayout",
    "DrSummary",
    "dr_followers",
    "dr_layout",
    "dr_states_of",
    "dr_states_table",
    "dr_summary",
]

_DEG = np.pi / 180.0
_DPH = _DEG / 3600.0  # deg/h -> rad/s
_SQRT_H = 60.0  # sqrt(3600 s)


@dataclass(frozen=True)
class DrLayout:
    """The DR states of one fusion.

    ``idx[p]``: the state index of platform p's heading correction (-1: no DR states);
    ``q[p]``: the heading, heading-rate and scale random walks' variance per second, the
    position's (per axis) and the heading's variance per metre travelled;
    ``prior``: the initial variances of all DR states, in state order; ``position_q[p]``:
    a follower's residual position noise per second (the kernel's ``q_coef``);
    ``rec``: the epochs at which the DR states are reported (ascending).
    """

    idx: NDArray[np.int64]
    q: FloatArray
    prior: FloatArray
    position_q: FloatArray
    rec: NDArray[np.int64]

    @property
    def active(self) -> bool:
        """Some platform carries DR states."""
        return bool((self.idx >= 0).any())


def _carries_dr(session: Session, pid: str) -> bool:
    """Followers do: their navigation is dead reckoning. Leaders are fixed by their own
    GNSS/INS fix (a position update), tags have no navigation of their own."""
    return session.platforms[pid].role == "follower"


def dr_followers(session: Session, moving: list[str], params: FusionParams) -> list[str]:
    """The platforms of ``moving`` that carry DR states in a fusion with ``params``."""
    return [p for p in moving if params.state == "dr" and _carries_dr(session, p)]


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
    q = np.zeros((n_plat, DR_STATES + 2))
    position_q = np.zeros(n_plat)
    prior: list[float] = []
    scale = drift_scale or {}
    followers = set(dr_followers(session, moving, params))
    if followers:
        walk = np.array(
            [
                (params.heading_walk_dpsh * _DEG / _SQRT_H) ** 2,
                (params.heading_rate_walk_dphpsh * _DPH / _SQRT_H) ** 2,
                (params.scale_walk_psh / _SQRT_H) ** 2,
                params.dr_distance_noise_m**2,
                (params.dr_heading_noise_deg * _DEG) ** 2,
            ]
        )
        first = [
            (params.heading_sigma_deg * _DEG) ** 2,
            (params.heading_rate_sigma_dph * _DPH) ** 2,
            params.scale_sigma**2,
        ]
        for p, pid in enumerate(moving):
            if pid not in followers:
                continue
            idx[p] = n_plat * dim + len(prior)
            factor = scale.get(pid, 1.0) ** 2
            q[p] = walk * factor
            position_q[p] = params.dr_position_sigma_mps**2 * factor
            prior.extend(first)
    rec = np.zeros(0, dtype=np.int64)
    if (idx >= 0).any() and epochs.shape[0] > 0:
        bins = np.floor((epochs - epochs[0]) / params.dr_states_every_s)
        rec = np.flatnonzero(np.diff(bins, prepend=-1.0) != 0).astype(np.int64)
    return DrLayout(idx=idx, q=q, prior=np.array(prior), position_q=position_q, rec=rec)


def dr_states_table(
    moving: list[str],
    epochs: FloatArray,
    layout: DrLayout,
    states: tuple[FloatArray, FloatArray],
    method: str = "",
) -> pd.DataFrame:
    """The DR states as the dead reckoning's errors, per follower and reported epoch
    (``DR_STATES_COLUMNS``, dr_states.csv; ``method`` fills its method column).

    ``states``: the values and variances at ``layout.rec`` (the kernels' DR output). The
    states are corrections (the DR increment times (1 + s) R(theta) is the true one, theta
    counter-clockwise about up); the table gives the DR's own errors in the heading
    convention of states.csv (clockwise from north), so that a DR heading that reads too
    far clockwise has a positive error: heading error theta (deg), heading-rate error
    omega (deg/h: the gyro bias as the heading sees it), scale error -s / (1 + s) (the DR
    increment is (1 + scale_error) times the true one), each with its 1-sigma (the
    scale's to first order).
    """
    values, variances = states
    times = epochs[layout.rec]
    frames = []
    if values.shape[0] == times.shape[0] and layout.active:
        n_pos = int(layout.idx[layout.idx >= 0].min())
        sig = np.sqrt(np.maximum(variances, 0.0))
        for p, pid in enumerate(moving):
            if layout.idx[p] < 0:
                continue
            e = int(layout.idx[p]) - n_pos
            s = values[:, e + 2]
            frames.append(
                pd.DataFrame(
                    {
                        "time": times,
                        "platform": pid,
                        "method": method,
                        "heading_error": np.degrees(values[:, e]),
                        "heading_rate_error": values[:, e + 1] / _DPH,
                        "scale_error": -s / (1.0 + s),
                        "sigma_heading_error": np.degrees(sig[:, e]),
                        "sigma_heading_rate_error": sig[:, e + 1] / _DPH,
                        "sigma_scale_error": sig[:, e + 2] / (1.0 + s) ** 2,
                    }
                )
            )
    if not frames:
        return pd.DataFrame({c: [] for c in DR_STATES_COLUMNS})
    return pd.concat(frames, ignore_index=True)[list(DR_STATES_COLUMNS)]


def dr_states_of(products: Mapping[str, PositionProduct]) -> pd.DataFrame | None:
    """dr_states.csv: every position method's DR states (its method column the method's
    name), by platform, method and time; None when no method has them."""
    parts = [
        product.dr_states.assign(method=method)
        for method, product in products.items()
        if product.dr_states is not None and len(product.dr_states)
    ]
    if not parts:
        return None
    frame = pd.concat(parts, ignore_index=True)
    frame = frame.sort_values(["platform", "method", "time"], kind="stable", ignore_index=True)
    return frame[list(DR_STATES_COLUMNS)]


@dataclass(frozen=True)
class DrSummary:
    """One follower's DR states over a run, for the summary and run.json: the heading
    error of largest magnitude (deg) and the heading-rate and scale errors' medians over
    time with the median 1-sigma (deg/h; a fraction)."""

    heading_error_max_deg: float
    heading_rate_error_dph: float
    heading_rate_sigma_dph: float
    scale_error: float
    scale_sigma: float


def dr_summary(frame: pd.DataFrame | None, method: str = "observed") -> dict[str, DrSummary]:
    """Per platform, :class:`DrSummary` of ``method``'s rows of a dr_states table."""
    if frame is None or not len(frame):
        return {}
    rows = frame[frame["method"] == method]
    out = {}
    for platform, part in rows.groupby("platform", sort=True, observed=True):
        heading = part["heading_error"].to_numpy(np.float64)
        out[str(platform)] = DrSummary(
            heading_error_max_deg=float(heading[np.argmax(np.abs(heading))]),
            heading_rate_error_dph=float(part["heading_rate_error"].median()),
            heading_rate_sigma_dph=float(part["sigma_heading_rate_error"].median()),
            scale_error=float(part["scale_error"].median()),
            scale_sigma=float(part["sigma_scale_error"].median()),
        )
    return out
