"""Fused states back to one Trajectory per platform, at the epochs or at the nav rate."""

from __future__ import annotations

import numpy as np

from coopproc.model import FloatArray, Session, Trajectory

__all__ = ["trajectories_from_states"]


def trajectories_from_states(
    session: Session,
    moving: list[str],
    epochs: FloatArray,
    nav: FloatArray,
    xs: FloatArray,
    var: FloatArray,
    dim: int,
    output: str,
    *,
    hold: bool,
) -> dict[str, Trajectory]:
    """One Trajectory per platform at the epochs, or at its nav times (``output="nav"``).

    At nav rate the correction (fused minus nav) is carried between epochs: held from the
    last epoch for the causal ``forward`` solution, linearly interpolated for the smoothed.
    """
    out: dict[str, Trajectory] = {}
    for p, pid in enumerate(moving):
        est = xs[:, p * dim : (p + 1) * dim]
        sig = np.full((epochs.shape[0], 3), np.nan)
        sig[:, :dim] = np.sqrt(np.maximum(var[:, p * dim : (p + 1) * dim], 0.0))
        if output == "ranges":
            enu = nav[p].copy()
            enu[:, :dim] = est
            out[pid] = Trajectory(pid, epochs.copy(), enu, sigma_enu_m=sig, source="fusion")
            continue
        traj = session.nav[pid]
        sel = (traj.time_s >= epochs[0]) & (traj.time_s <= epochs[-1])
        times = traj.time_s[sel]
        enu = traj.enu_m[sel].copy()
        corr = est - nav[p, :, :dim]
        if hold:
            k = np.clip(np.searchsorted(epochs, times, side="right") - 1, 0, None)
            enu[:, :dim] += corr[k]
            sig_t = sig[k]
        else:
            sig_t = np.full((times.shape[0], 3), np.nan)
            for axis in range(dim):
                enu[:, axis] += np.interp(times, epochs, corr[:, axis])
                sig_t[:, axis] = np.interp(times, epochs, sig[:, axis])
        out[pid] = Trajectory(pid, times, enu, sigma_enu_m=sig_t, source="fusion")
    return out
