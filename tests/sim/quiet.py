"""A simulator parameter set with every dead-reckoning error off (shared by the sim tests)."""

from __future__ import annotations

from coopproc.sim import SimParams


def quiet_params(**changes: float) -> SimParams:
    """SimParams with no gyro, odometer, initial or height error, then ``changes``."""
    base = {
        "gyro_bias_dph": 0.0, "gyro_arw_dpsh": 0.0, "heading_init_sigma_deg": 0.0,
        "odo_scale_sigma": 0.0, "odo_noise_m": 0.0, "init_error_m": 0.0, "height_rw_m": 0.0,
    }  # fmt: skip
    base.update(changes)
    return SimParams(**base)  # type: ignore[arg-type]
