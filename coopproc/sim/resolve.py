"""A scenario's effective simulation parameters, and the refusal of given ones that do nothing.

The scenario's defaults with the overrides applied (unknown names and parameters that
cannot act are ConfigErrors, :mod:`coopproc.sim.options`); the scenario's own NLOS events,
outages and nav gaps move with ``duration_s`` (:func:`_rescale`), given ones stay as given
but must hold an epoch of the simulated session (:func:`check_epochs`,
:func:`check_gaps`). Used by :func:`coopproc.sim.engine.simulate`.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping
from typing import Any, TypeVar

import numpy as np

from coopproc.configtools import nearest
from coopproc.errors import ConfigError
from coopproc.sim.options import changed_options, check_options
from coopproc.sim.params import NavGapSpec, NlosSpec, OutageSpec, SimParams, apply_overrides
from coopproc.sim.scenarios import SCENARIOS, Actor

__all__ = [
    "check_epochs",
    "check_gaps",
    "logged_mask",
    "nav_times_rel",
    "resolve",
    "scenario_params",
]


def scenario_params(scenario: str, **overrides: Any) -> SimParams:
    """The effective parameters of ``scenario`` with ``overrides`` applied.

    A parameter set where it can do nothing is a ConfigError
    (:func:`coopproc.sim.options.check_options`). The scenario's own NLOS events, outages
    and nav gaps move with ``duration_s`` (:func:`_rescale`); given ones stay as given.
    """
    from coopproc.sim.gnss_obs import gnss_session_params  # needs the nav file: late

    params, given, _ = resolve(scenario, overrides)
    return gnss_session_params(params, given)  # with gnss_obs: the ephemerides' time


def resolve(
    scenario: str, overrides: Mapping[str, Any]
) -> tuple[SimParams, frozenset[str], tuple[str, ...]]:
    """The effective parameters, the names given (not None) and the names whose value
    differs from the scenario's."""
    base = _scenario_defaults(scenario)
    params = apply_overrides(base, overrides)
    changed = changed_options(base, params)
    check_options(scenario, params, changed)
    given = frozenset(key for key, value in overrides.items() if value is not None)
    if params.duration_s == base.duration_s:
        return params, given, changed
    span = (base.duration_s, params.duration_s, nav_times_rel(params))
    ranging = 1.0 / params.range_rate_hz
    changes: dict[str, Any] = {}
    if "nlos_events" not in given:
        changes["nlos_events"] = _rescale(params.nlos_events, *span, ranging)
    if "outages" not in given:
        changes["outages"] = _rescale(params.outages, *span, ranging)
    if "nav_gaps" not in given:
        changes["nav_gaps"] = _rescale(params.nav_gaps, *span, 0.0)
    return dataclasses.replace(params, **changes), given, changed


@functools.cache
def _scenario_defaults(scenario: str) -> SimParams:
    if scenario not in SCENARIOS:
        raise ConfigError(f"unknown scenario '{scenario}'{nearest(scenario, SCENARIOS)}")
    return apply_overrides(SimParams(), SCENARIOS[scenario].defaults)


_Spec = TypeVar("_Spec", NlosSpec, OutageSpec, NavGapSpec)


def _rescale(
    items: tuple[_Spec, ...],
    nominal_s: float,
    duration_s: float,
    nav_times: np.ndarray,
    min_length_s: float,
) -> tuple[_Spec, ...]:
    """A scenario's NLOS events, outages or nav gaps in a session of another length.

    Each moves to the same fraction of the session and keeps its length, ending at the
    latest 1 s before the session end (and at the last nav epoch); a nav gap that reached
    the session end still does. Dropped when it no longer fits: shorter than
    ``min_length_s`` (events and outages: one ranging period, so that every pair has a
    ranging epoch inside) or holding no nav epoch.
    """
    last = float(nav_times[-1])
    out = []
    for item in items:
        start = item.start_s * duration_s / nominal_s
        if isinstance(item, NavGapSpec) and item.end_s >= nominal_s:
            end = duration_s
        else:
            end = min(start + (item.end_s - item.start_s), duration_s - 1.0, last)
        holds = bool(((nav_times >= start - 1e-9) & (nav_times <= end + 1e-9)).any())
        if end > start and end - start >= min_length_s and holds:
            out.append(dataclasses.replace(item, start_s=start, end_s=end))
    return tuple(out)


def nav_times_rel(params: SimParams) -> np.ndarray:
    """The nav-rate time grid of a session, seconds from its start (the truth's too)."""
    dt = 1.0 / params.nav_rate_hz
    return np.round(dt * np.arange(int(np.floor(params.duration_s / dt + 1e-9)) + 1), 9)


def logged_mask(t_rel: np.ndarray, gaps: tuple[NavGapSpec, ...], pid: str) -> np.ndarray:
    """Nav epochs of ``pid`` outside its gaps (both ends of a gap included in it)."""
    keep = np.ones(t_rel.shape[0], dtype=bool)
    for gap in gaps:
        if gap.platform == pid:
            keep &= ~((t_rel >= gap.start_s - 1e-9) & (t_rel <= gap.end_s + 1e-9))
    return keep


def check_epochs(
    params: SimParams,
    given: frozenset[str],
    range_times: Mapping[str, np.ndarray],
    nav_times: np.ndarray,
) -> None:
    """Refuse NLOS events, outages and nav gaps given explicitly that hold no epoch.

    (The scenario's own, moved with the session length, always hold one: :func:`_rescale`.)
    """
    session = f"the session is 0-{params.duration_s:g} s"
    if "nlos_events" in given:
        for event in params.nlos_events:
            t = range_times[event.pair]
            if not ((t >= event.start_s) & (t <= event.end_s)).any():
                raise ConfigError(
                    f"simulation parameter 'nlos_events': the event on {event.pair} at "
                    f"{event.start_s:g}-{event.end_s:g} s holds no range of the pair "
                    f"({session}, ranges at {params.range_rate_hz:g} Hz)"
                )
    if "outages" in given:
        every = np.concatenate([*range_times.values(), np.empty(0)])
        for outage in params.outages:
            if not ((every >= outage.start_s) & (every <= outage.end_s)).any():
                raise ConfigError(
                    f"simulation parameter 'outages': the outage at {outage.start_s:g}-"
                    f"{outage.end_s:g} s removes no range ({session})"
                )
    if "nav_gaps" in given:
        for gap in params.nav_gaps:
            if logged_mask(nav_times, (gap,), gap.platform).all():
                raise ConfigError(
                    f"simulation parameter 'nav_gaps': the gap of {gap.platform} at "
                    f"{gap.start_s:g}-{gap.end_s:g} s removes no nav row ({session}, nav "
                    f"at {params.nav_rate_hz:g} Hz)"
                )


def check_gaps(params: SimParams, actors: tuple[Actor, ...], t_rel: np.ndarray) -> None:
    """Refuse nav gaps of a platform without navigation, or leaving it < 2 nav epochs."""
    navigating = sorted(a.id for a in actors if a.nav != "none")
    for gap in params.nav_gaps:
        if gap.platform not in navigating:
            raise ConfigError(
                f"nav gap of '{gap.platform}': no such platform with navigation "
                f"(platforms: {', '.join(navigating)})"
            )
    for pid in navigating:
        if logged_mask(t_rel, params.nav_gaps, pid).sum() < 2:
            raise ConfigError(f"nav gaps of '{pid}' leave fewer than 2 nav epochs")
