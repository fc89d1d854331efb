"""The localizer's inputs, gathered once from a Session into dense arrays.

Filter epochs are the times of the target's ranges to its auxiliaries (within the spans
of the target's and the auxiliary's navigation). At each epoch every auxiliary has a
range or NaN; auxiliary positions are their navigation (GNSS) solutions interpolated
at the epoch, or for an anchor without navigation its surveyed ``position``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from coopproc.errors import StageError
from coopproc.estimation.locate_result import LocateInputs
from coopproc.model import Session, pair_name
from coopproc.stages.particle.increments import dr_increments

__all__ = ["DEFAULT_SIGMA_M", "gather_inputs"]

#: Ranging 1-sigma used when neither the ranges nor session.toml give one, metres.
DEFAULT_SIGMA_M = 0.2


def _sigma_default(session: Session, sigma_m: float) -> float:
    if sigma_m > 0:
        return sigma_m
    if session.config.uwb_sigma_m is not None and session.config.uwb_sigma_m > 0:
        return float(session.config.uwb_sigma_m)
    return DEFAULT_SIGMA_M


def gather_inputs(
    session: Session, target: str, aux: Sequence[str], sigma_m: float = 0.0
) -> LocateInputs:
    """Epochs, eq. (3) increments, ranges and auxiliary positions for ``target``.

    ``sigma_m`` > 0 overrides the ranging sigma; otherwise the ranges' ``sigma`` column is
    used where given, else session.toml ``[uwb] sigma``, else :data:`DEFAULT_SIGMA_M`.
    """
    aux = tuple(aux)
    if not aux:
        raise StageError("locate: give at least one auxiliary (--aux)")
    if target in aux:
        raise StageError(f"locate: the target '{target}' cannot be its own auxiliary")
    if len(set(aux)) != len(aux):
        raise StageError(f"locate: auxiliary listed twice in {','.join(aux)}")
    known = ", ".join(sorted(session.nav)) or "none"
    if target not in session.nav:
        raise StageError(f"locate: platform '{target}' has no navigation (platforms: {known})")
    for pid in aux:
        spec = session.platforms.get(pid)
        fixed = spec is not None and spec.position_enu_m is not None
        if pid not in session.nav and not fixed:
            raise StageError(
                f"locate: platform '{pid}' has no navigation and no anchor position "
                f"(platforms: {known})"
            )
    nav_t = session.nav[target]
    t_lo, t_hi = nav_t.span_s
    fallback = _sigma_default(session, 0.0)
    frame = session.ranges.frame
    per_aux = []
    for a in aux:
        rows = frame[frame["pair"] == pair_name(target, a)]
        lo, hi = session.nav[a].span_s if a in session.nav else (t_lo, t_hi)
        keep = (rows["time"] >= max(t_lo, lo)) & (rows["time"] <= min(t_hi, hi))
        rows = rows[keep & np.isfinite(rows["range"].to_numpy(dtype=np.float64))]
        if rows.empty:
            raise StageError(
                f"locate: no ranges between '{target}' and '{a}' while both have navigation"
            )
        sig = rows["sigma"].to_numpy(dtype=np.float64)
        sig = np.where(np.isfinite(sig) & (sig > 0), sig, fallback)
        if sigma_m > 0:
            sig = np.full_like(sig, sigma_m)
        # A->B and B->A at the same time: one measurement, their mean
        t_rows = rows["time"].to_numpy(dtype=np.float64)
        times, inv = np.unique(t_rows, return_inverse=True)
        count = np.bincount(inv)
        rng = np.bincount(inv, rows["range"].to_numpy(dtype=np.float64)) / count
        sg = np.bincount(inv, sig) / count
        per_aux.append((times, rng, sg))
    time_s = np.unique(np.concatenate([p[0] for p in per_aux]))
    if time_s.shape[0] < 2:
        raise StageError(f"locate: '{target}' has fewer than 2 range epochs to its auxiliaries")
    n_e, n_j = time_s.shape[0], len(aux)
    range_m = np.full((n_e, n_j), np.nan)
    sig_m = np.full((n_e, n_j), np.nan)
    aux_en = np.empty((n_e, n_j, 2))
    for j, (times, rng, sg) in enumerate(per_aux):
        idx = np.searchsorted(time_s, times)
        range_m[idx, j] = rng
        sig_m[idx, j] = sg
        if aux[j] not in session.nav:  # an anchor: its surveyed position
            position = session.platforms[aux[j]].position_enu_m
            assert position is not None
            aux_en[:, j] = position[:2]
            continue
        nav_a = session.nav[aux[j]]
        aux_en[:, j, 0] = np.interp(time_s, nav_a.time_s, nav_a.enu_m[:, 0])
        aux_en[:, j, 1] = np.interp(time_s, nav_a.time_s, nav_a.enu_m[:, 1])
    return LocateInputs(
        target=target,
        aux=aux,
        time_s=time_s,
        increments=dr_increments(nav_t, time_s),
        range_m=range_m,
        sigma_m=sig_m,
        aux_en_m=aux_en,
    )
