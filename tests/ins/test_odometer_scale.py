"""The odometer scale estimated against an INS track (coopproc.stages.ins.ins_setup)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from coopproc.stages.ins.ins_setup import odometer_scale


def _track(t: np.ndarray) -> SimpleNamespace:
    """A car turning at 8 m/s (east/north velocity), stopped for the first 10 s."""
    speed = np.where(t < 10.0, 0.0, 8.0)
    yaw = 0.05 * t
    vel = np.column_stack([speed * np.cos(yaw), speed * np.sin(yaw), np.zeros_like(t)])
    return SimpleNamespace(vel_enu=vel, enu_m=np.zeros((t.size, 3)))


def test_scale_recovered_from_a_noisy_odometer() -> None:
    t_ins = np.arange(0.0, 60.0, 0.01)
    track = _track(t_ins)
    t_odo = np.arange(0.05, 60.0, 0.1)
    true_speed = np.where(t_odo < 10.0, 0.0, 8.0)
    rng = np.random.default_rng(3)
    odo = (1.0 - 0.0045) * true_speed + rng.normal(0.0, 0.02, t_odo.size)
    k = odometer_scale(t_odo, odo, track, t_ins)
    assert k is not None and abs(k + 0.0045) < 3e-4, k


def test_no_scale_without_motion() -> None:
    t_ins = np.arange(0.0, 9.0, 0.01)
    t_odo = np.arange(0.05, 9.0, 0.1)
    assert odometer_scale(t_odo, np.zeros(t_odo.size), _track(t_ins), t_ins) is None
