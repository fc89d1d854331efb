"""The ``locate`` stage: single-auxiliary cooperative localization (paper 004).

:func:`locate` gathers the target's eq. (3) increments and the auxiliaries' ranges and
positions, runs the AACOPF, the standard PF and the EKF on identical inputs, analyzes
observability (eq. (17)-(19)) and returns the ``locate.csv`` / ``locate_summary.csv``
tables of DATA.md.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from coopproc.configtools import from_table
from coopproc.estimation.angles import heading_deg, wrap_deg
from coopproc.estimation.locate_result import LocateInputs, LocateResult, Observability, Track
from coopproc.model import FloatArray, Session
from coopproc.stages.particle.aacopf import run_aacopf
from coopproc.stages.particle.ekf import run_ekf
from coopproc.stages.particle.increments import rotation_between
from coopproc.stages.particle.inputs import gather_inputs
from coopproc.stages.particle.observability import analyze
from coopproc.stages.particle.params import LocateParams
from coopproc.stages.particle.pf import run_pf
from coopproc.stages.particle.progress import ProgressFn

__all__ = [
    "LOCATE_COLUMNS",
    "LOCATE_SUMMARY_COLUMNS",
    "locate",
    "locate_params",
    "observability_table",
    "with_seed",
]

LOCATE_COLUMNS: tuple[str, ...] = ("time", "method", "east", "north", "heading", "error_h")
LOCATE_SUMMARY_COLUMNS: tuple[str, ...] = (
    "method",
    "initial_azimuth",
    "azimuth_error",
    "converged_at",
    "rmse_h",
    "observable",
    "unique",
    "modes",
    "runner_up_azimuth",
    "runner_up_weight",
)


def locate_params(table: Mapping[str, Any] | None, where: str = "[locate]") -> LocateParams:
    """LocateParams from a ``[locate]`` TOML table (``lambda`` is accepted for ``lambda_``)."""
    data = dict(table or {})
    if "lambda" in data:
        data["lambda_"] = data.pop("lambda")
    if isinstance(data.get("methods"), list):
        data["methods"] = tuple(data["methods"])
    return from_table(LocateParams, data, where)


def _reference(
    session: Session, inputs: LocateInputs, params: LocateParams
) -> tuple[FloatArray | None, float | None]:
    ref = session.reference.get(inputs.target)
    if ref is None or len(ref) < 2:
        return None, None
    en = ref.interpolate(inputs.time_s)[:, :2]
    steps = np.diff(en, axis=0)
    psi = rotation_between(inputs.increments.step_own_m, steps, params.azimuth_window_m)
    if psi is None:
        return en, None
    init = float(heading_deg(inputs.increments.theta0_rad + psi))
    return en, init


def _observability(inputs: LocateInputs, track: Track, tol: float) -> Observability:
    """Eq. (17)-(19) along the dead-reckoned path placed by ``track``'s final estimate.

    The linearization points must obey eq. (3) themselves (R_k assumes p_t - p_0 is the
    sum of the steps), so the path is the target's own DR rotated to the estimated
    initial azimuth and shifted to the estimated last position.
    """
    inc = inputs.increments
    phi_step = track.initial_azimuth_rad + (inc.theta_rad - inc.theta0_rad)
    steps = inc.delta_l_m[:, None] * np.column_stack([np.cos(phi_step), np.sin(phi_step)])
    path = np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)])
    path += np.array([track.east_m[-1], track.north_m[-1]]) - path[-1]
    return analyze(path, inputs.aux_en_m, np.isfinite(inputs.range_m), inc.delta_l_m, phi_step, tol)


def _converged_at(time_s: FloatArray, err: FloatArray, limit_m: float) -> float | None:
    """First time after which the error stays below ``limit_m`` (NaN counts as not)."""
    bad = ~(err < limit_m)
    if bad.all():
        return None
    if not bad.any():
        return float(time_s[0])
    last_bad = int(np.nonzero(bad)[0][-1])
    return None if last_bad + 1 >= time_s.shape[0] else float(time_s[last_bad + 1])


def locate(
    session: Session,
    target: str,
    aux: Sequence[str],
    params: LocateParams,
    progress: ProgressFn | None = None,
) -> LocateResult:
    """Localize ``target`` from its ranges to ``aux`` with every method in ``params``.

    ``progress`` is called after every epoch of every method (method, done, total).
    """
    inputs = gather_inputs(session, target, aux, params.range_sigma_m)
    runners = {
        "aacopf": lambda: run_aacopf(inputs, params, params.seed, progress),
        "pf": lambda: run_pf(inputs, params, params.seed, progress),
        "ekf": lambda: run_ekf(inputs, params, progress),
    }
    tracks = {m: runners[m]() for m in params.methods}
    obs = _observability(inputs, tracks[params.methods[0]], params.observability_tol)
    ref_en, ref_init = _reference(session, inputs, params)
    rows = []
    summary = []
    mode_notes: list[str] = []
    for method, tr in tracks.items():
        if ref_en is not None:
            err = np.hypot(tr.east_m - ref_en[:, 0], tr.north_m - ref_en[:, 1])
        else:
            err = np.full(inputs.n_epochs, np.nan)
        rows.append(
            pd.DataFrame(
                {
                    "time": inputs.time_s,
                    "method": method,
                    "east": tr.east_m,
                    "north": tr.north_m,
                    "heading": heading_deg(tr.phi_rad),
                    "error_h": err,
                }
            )
        )
        init_deg = float(heading_deg(tr.initial_azimuth_rad))
        az_err = np.nan if ref_init is None else float(wrap_deg(init_deg - ref_init))
        have = np.isfinite(err)
        conv = _converged_at(inputs.time_s, err, params.converge_m) if obs.observable else None
        # mode safety (issue 17): the final estimate's modes, weights >= 1e-6 counted
        modes = [m for m in tr.modes if m.weight >= 1e-6]
        unique = len(modes) < 2 or modes[1].weight < params.unique_weight
        runner = None if len(modes) < 2 else modes[1]
        turned = float(inputs.increments.heading_own_rad()[-1] - inputs.increments.theta0_rad)
        if runner is not None and not unique:
            mode_notes.append(
                f"locate: {method}: the solution is not unique: a second mode at initial "
                f"azimuth {float(heading_deg(runner.phi_rad - turned)):.1f} deg holds "
                f"{100 * runner.weight:.1f}% of the weight"
            )
        summary.append(
            {
                "method": method,
                "initial_azimuth": init_deg,
                "azimuth_error": az_err,
                "converged_at": np.nan if conv is None else conv,
                "rmse_h": float(np.sqrt(np.mean(err[have] ** 2))) if have.any() else np.nan,
                "observable": int(obs.observable),
                "unique": int(unique) if tr.modes else np.nan,
                "modes": len(modes) if tr.modes else np.nan,
                "runner_up_azimuth": np.nan
                if runner is None
                else float(heading_deg(runner.phi_rad - turned)),
                "runner_up_weight": np.nan if runner is None else runner.weight,
            }
        )
    warnings = []
    if not obs.observable:
        s1, s2, s3 = obs.singular_values
        warnings.append(
            f"locate: the geometry is not observable (singular values of R_k {s1:.4g}, "
            f"{s2:.4g}, {s3:.4g}; eq. (19)): the auxiliary is static or keeps the same "
            "bearing, so position and azimuth are not determined"
        )
    warnings += mode_notes
    if "aacopf" in tracks and tracks["aacopf"].rejected is not None:
        frac = tracks["aacopf"].rejected.mean(axis=0)
        for j, a in enumerate(inputs.aux):
            if frac[j] > 0:
                warnings.append(
                    f"locate: auxiliary '{a}' rejected at {100 * frac[j]:.1f}% of the epochs "
                    "(step 3: residual mean > Omega1 and variance > Omega2, or its own "
                    "ranges scatter beyond Omega2)"
                )
    table = pd.concat(rows, ignore_index=True)[list(LOCATE_COLUMNS)]
    return LocateResult(
        table=table,
        summary=pd.DataFrame(summary, columns=list(LOCATE_SUMMARY_COLUMNS)),
        observability=obs,
        tracks=tracks,
        inputs=inputs,
        reference_en_m=ref_en,
        reference_initial_azimuth_deg=ref_init,
        warnings=tuple(warnings),
    )


def with_seed(params: LocateParams, seed: int | None) -> LocateParams:
    """``params`` with another seed (None: unchanged)."""
    return params if seed is None else dataclasses.replace(params, seed=seed)


def observability_table(result: LocateResult) -> pd.DataFrame:
    """``observability.csv``: the singular values of R_k (eq. (19)) and the verdict."""
    obs = result.observability
    start = obs.observable_from
    return pd.DataFrame(
        {
            "sigma1": [obs.singular_values[0]],
            "sigma2": [obs.singular_values[1]],
            "sigma3": [obs.singular_values[2]],
            "observable": [int(obs.observable)],
            "observable_from": [np.nan if start is None else float(result.inputs.time_s[start])],
        }
    )
