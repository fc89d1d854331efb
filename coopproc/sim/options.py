"""Which simulation parameters can act where: the rest is refused, not ignored.

A parameter set to a value other than the scenario's own, where it cannot change the
session, is a one-line :class:`~coopproc.errors.ConfigError` naming it and where it
applies, instead of being recorded in ``truth/params.toml`` and ignored. Three rules:

- the scenario's world has nothing for it to act on (:attr:`Scenario.unused
  <coopproc.sim.scenarios.Scenario.unused>`: no GNSS/INS leader in ``anchors``, no
  auxiliary outside ``single-auxiliary``, no formation whose distances could breathe);
- it needs another parameter or a session long enough (:data:`NEEDS`);
- ``exact_ranges`` makes every range the true distance, so the range-error parameters
  (:data:`RANGE_ERROR_OPTIONS`) cannot act with it.

What needs the simulated world (an NLOS event, outage or nav gap given explicitly that
holds no epoch, ``nlos_sigma_m`` in a session without NLOS events) the engine checks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable

import numpy as np

from coopproc.errors import ConfigError
from coopproc.sim.params import SimParams
from coopproc.sim.scenarios import SCENARIOS

__all__ = ["NEEDS", "RANGE_ERROR_OPTIONS", "applies_to", "changed_options", "check_options"]

#: What ``exact_ranges`` leaves out: these parameters only shape the range errors.
RANGE_ERROR_OPTIONS = (
    "uwb_noise_m",
    "dropout_rate",
    "gross_error_rate",
    "gross_error_m",
    "nlos_sigma_m",
    "nlos_events",
    "random_nlos_per_pair_hour",
    "outages",
    "aux2_bias_m",
    "aux2_noise_m",
    "aux3_tail_m",
)


def _reference_span_s(p: SimParams) -> float:
    """Length of the reference time grid (what places its float segments), s."""
    return float(np.floor(p.duration_s * p.ref_rate_hz + 1e-9) / p.ref_rate_hz)


def _float_segments(p: SimParams) -> str | None:
    if _reference_span_s(p) > 60.0:
        return None
    return (
        f"in a session of {p.duration_s:g} s: float (Q = 2) reference segments need more than 60 s"
    )


def _float_noise(p: SimParams) -> str | None:
    if p.float_fraction == 0:
        return "without float reference segments (float_fraction = 0)"
    return _float_segments(p)


def _second_auxiliary(p: SimParams) -> str | None:
    if p.second_aux or p.platforms >= 3:
        return None
    return "without the second auxiliary A2 (second_aux = true or --platforms 3)"


def _third_auxiliary(p: SimParams) -> str | None:
    if p.platforms >= 4:
        return None
    return "without the third auxiliary A3 (--platforms 4)"


def _aux1_moves(p: SimParams) -> str | None:
    if p.aux_static:
        return "with aux_static = true (A1 never moves)"
    if p.aux1_moves_at_s < p.duration_s:
        return None
    return f"at or after the session end ({p.duration_s:g} s)"


def _random_nlos(p: SimParams) -> str | None:
    if p.duration_s >= 120.0:
        return None
    return f"in a session of {p.duration_s:g} s: random NLOS events need 120 s or more"


def _slips(p: SimParams) -> str | None:
    if p.duration_s > 20.0:
        return None
    return f"in a session of {p.duration_s:g} s: wheel slips need more than 20 s"


def _imu(p: SimParams) -> str | None:
    return None if p.imu_rate_hz > 0 else "without IMU data (imu_rate_hz = 0; e.g. --imu 100)"


def _odometer(p: SimParams) -> str | None:
    if p.imu_body != "vehicle":
        return "without an odometer (imu_body = multirotor: no wheels)"
    return _imu(p)


#: What only acts with ``gnss_obs`` (coopproc.sim.gnss_obs).
GNSS_OPTIONS = (
    "gnss_nav", "gnss_rinex_version", "gnss_rate_hz", "gnss_mask_deg", "gnss_code_sigma_m",
    "gnss_doppler_sigma_hz", "gnss_multipath_m", "gnss_multipath_tau_s", "gnss_tropo_error",
    "gnss_iono_error", "canyon",
)  # fmt: skip


def _gnss(p: SimParams) -> str | None:
    return None if p.gnss_obs else "without GNSS observations (gnss_obs = false; --gnss-obs)"


#: Parameters that act only together with another one, or in a session long enough:
#: name -> a function of the effective parameters that says why not (None: it acts).
NEEDS: dict[str, Callable[[SimParams], str | None]] = {
    "gross_error_m": lambda p: (
        None if p.gross_error_rate > 0 else "without gross errors (gross_error_rate = 0)"
    ),
    "leader_vel_sigma_mps": lambda p: (
        None if p.leader_velocity else "without leader velocities (leader_velocity = false)"
    ),
    "aux2_bias_m": _second_auxiliary,
    "aux2_noise_m": _second_auxiliary,
    "aux3_tail_m": _third_auxiliary,
    "aux1_moves_at_s": _aux1_moves,
    "float_fraction": _float_segments,
    "float_sigma_m": _float_noise,
    "random_nlos_per_pair_hour": _random_nlos,
    "slip_rate_per_hour": _slips,
    "imu_grade": _imu,
    "imu_earth_rate": _imu,
    "odo_rate_hz": _odometer,
    "imu_body": _imu,
    **dict.fromkeys(GNSS_OPTIONS, _gnss),
}


def changed_options(base: SimParams, params: SimParams) -> tuple[str, ...]:
    """The parameters whose value in ``params`` differs from ``base`` (the scenario's)."""
    return tuple(
        f.name
        for f in dataclasses.fields(SimParams)
        if getattr(params, f.name) != getattr(base, f.name)
    )


def applies_to(name: str) -> tuple[str, ...]:
    """The scenarios whose world parameter ``name`` can act on."""
    return tuple(key for key, spec in SCENARIOS.items() if name not in spec.unused)


def check_options(scenario: str, params: SimParams, changed: Iterable[str]) -> None:
    """Raise ConfigError for the first of ``changed`` that can do nothing in ``scenario``
    with ``params`` (the effective parameters)."""
    names = tuple(changed)
    unused = SCENARIOS[scenario].unused
    for name in names:
        if name in unused:
            raise ConfigError(
                f"simulation parameter '{name}' does nothing in scenario '{scenario}' "
                f"({unused[name]}); it applies to: {', '.join(applies_to(name))}"
            )
    if params.exact_ranges:
        for name in names:
            if name in RANGE_ERROR_OPTIONS:
                raise ConfigError(
                    f"simulation parameter '{name}' does nothing with exact_ranges = true "
                    "(every range is the true distance)"
                )
    for name in names:
        why = NEEDS[name](params) if name in NEEDS else None
        if why is not None:
            raise ConfigError(f"simulation parameter '{name}' does nothing {why}")
