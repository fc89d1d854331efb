"""UWB two-way ranges between platforms: noise, NLOS events, gross errors, dropouts.

For every pair, ranges are taken at the ranging rate, each pair at its own small time
offset inside the ranging period (the DW1000 polls pairs one after another). A range is

    range = |p_i(t) - p_j(t)| + n + b_pair + nlos + gross,    rounded to the millimetre

with n ~ N(0, uwb_noise^2) (or Laplace for a pair with non-Gaussian ranging, paper 004
section 5.2, or Student t for a heavy-tailed one), and during an NLOS event on the pair
every epoch gets nlos ~ N(mu, 0.1^2) (paper 000 section 4.3), clipped at 0 because a
blocked path is never shorter; an event with ``wander_m`` has a slowly varying mean
mu(t) instead (:func:`nlos_mean_m`). Epochs
are then dropped at random (dropouts) and during outages (paper 003 section 3.4).
With ``exact_ranges`` a range is the true distance itself (not even rounded).
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import FloatArray, Trajectory, pair_name
from coopproc.sim.params import NlosSpec, OutageSpec, SimParams

__all__ = ["PairModel", "RangeOutput", "nlos_mean_m", "range_times_rel", "simulate_ranges"]


@dataclass(frozen=True)
class PairModel:
    """One ranging link and its error model (``a`` initiates on even epochs)."""

    a: str
    b: str
    bias_m: float = 0.0
    #: Laplace scale of the noise instead of the Gaussian uwb_noise_m; 0: Gaussian.
    laplace_m: float = 0.0
    #: Scale of Student-t (2 dof) noise instead of the Gaussian: heavy tails; 0: Gaussian.
    student_t_m: float = 0.0
    #: Offset of the pair's epochs in the ranging period, s; None: 13 ms + 21 ms per pair
    #: (a schedule of the scenario's own: the quadrotor's tags poll anchors in turn).
    offset_s: float | None = None

    @property
    def pair(self) -> str:
        return pair_name(self.a, self.b)


@dataclass(frozen=True, eq=False)
class RangeOutput:
    """The range table plus its truth."""

    ranges: pd.DataFrame  # time, pair, from, to, range, sigma[, rssi]
    distances: pd.DataFrame  # time, pair, distance, error
    nlos_events: pd.DataFrame  # pair, start, end, nominal_mean, realized_mean, epochs
    gross_errors: pd.DataFrame  # time, pair, error


def _pair_rng(seed: int, pair: str) -> np.random.Generator:
    return np.random.default_rng([seed, zlib.crc32(f"uwb:{pair}".encode())])


def nlos_mean_m(event: NlosSpec, t_rel_s: FloatArray, seed: int) -> FloatArray:
    """mu(t) of an event at ``t_rel_s`` (seconds from the session start).

    mean_m + wander_m (sin(w1 (t - start) + p1) + sin(w2 (t - start) + p2)) / 2, periods
    uniform in 60-200 s and phases from a stream of the event's own, so |mu - mean_m| <=
    wander_m; the constant mean_m without wander.
    """
    if event.wander_m == 0.0:
        return np.full(t_rel_s.shape, event.mean_m)
    key = f"nlos-wander:{event.pair}:{event.start_s:.3f}"
    rng = np.random.default_rng([seed, zlib.crc32(key.encode())])
    omega = 2.0 * np.pi / rng.uniform(60.0, 200.0, size=2)
    phase = rng.uniform(0.0, 2.0 * np.pi, size=2)
    dt = t_rel_s[:, None] - event.start_s
    wave = np.sin(omega[None, :] * dt + phase[None, :]).sum(axis=1) / 2.0
    return np.asarray(event.mean_m + event.wander_m * wave, dtype=np.float64)


def range_times_rel(
    truth: Mapping[str, Trajectory], links: Sequence[PairModel], params: SimParams, start_s: float
) -> dict[str, FloatArray]:
    """Ranging epochs of every link over the truth's common span, s from ``start_s``.

    Each pair at the ranging rate with its own offset in the period (13 ms + 21 ms per
    pair in sorted order, or the link's ``offset_s``), as a DW1000 polls pairs in turn.
    """
    period = 1.0 / params.range_rate_hz
    t_end = min(float(traj.time_s[-1]) for traj in truth.values()) - start_s
    out = {}
    for index, link in enumerate(sorted(links, key=lambda item: item.pair)):
        offset = (0.013 + 0.021 * index) % period if link.offset_s is None else link.offset_s
        t_rel = np.round(
            offset + period * np.arange(int(np.floor((t_end - offset) / period)) + 1), 6
        )
        out[link.pair] = t_rel[t_rel <= t_end + 1e-9]
    return out


def simulate_ranges(
    truth: Mapping[str, Trajectory],
    links: Sequence[PairModel],
    params: SimParams,
    events: Sequence[NlosSpec],
    outages: Sequence[OutageSpec],
    start_s: float,
    seed: int,
) -> RangeOutput:
    """Ranges of every link over the truth's common span; times in the session base.

    An NLOS event none of whose epochs is written (dropouts, outages) is left out of
    the truth's ``nlos_events``.
    """
    times = range_times_rel(truth, links, params, start_s)
    ranges: list[dict[str, np.ndarray]] = []
    dists: list[dict[str, np.ndarray]] = []
    gross_rows: list[dict[str, np.ndarray]] = []
    event_rows: list[dict[str, object]] = []
    for link in sorted(links, key=lambda item: item.pair):
        pair = link.pair
        rng = _pair_rng(seed, pair)
        t_rel = times[pair]
        n = t_rel.shape[0]
        time = start_s + t_rel
        distance = np.linalg.norm(
            truth[link.a].interpolate(time) - truth[link.b].interpolate(time), axis=1
        )
        if link.laplace_m > 0:
            error = rng.laplace(0.0, link.laplace_m, size=n)
        elif link.student_t_m > 0:
            error = link.student_t_m * rng.standard_t(2.0, size=n)
        else:
            error = rng.normal(0.0, params.uwb_noise_m, size=n)
        error = error + link.bias_m
        nlos_total = np.zeros(n)
        pair_events = sorted((e for e in events if e.pair == pair), key=lambda e: e.start_s)
        nlos_added = []
        for event in pair_events:
            mask = (t_rel >= event.start_s) & (t_rel <= event.end_s)
            draw: FloatArray
            if event.wander_m == 0.0:
                draw = np.asarray(rng.normal(event.mean_m, params.nlos_sigma_m, size=n))
            else:
                draw = nlos_mean_m(event, t_rel, seed) + rng.normal(0.0, params.nlos_sigma_m, n)
            added = np.maximum(draw, 0.0) * mask
            nlos_total += added
            nlos_added.append((event, mask, added))
        gross_mask: NDArray[np.bool_] = np.asarray(rng.uniform(size=n) < params.gross_error_rate)
        gross = np.where(
            gross_mask,
            params.gross_error_m
            * rng.uniform(0.75, 1.25, size=n)
            * rng.choice([-1.0, 1.0], size=n),
            0.0,
        )
        keep: NDArray[np.bool_] = np.asarray(rng.uniform(size=n) >= params.dropout_rate)
        for outage in outages:
            keep &= ~((t_rel >= outage.start_s) & (t_rel <= outage.end_s))
        if params.exact_ranges:  # the engine passes no events and no outages then
            measured = distance.copy()
            keep[:] = True
            gross_mask[:] = False
        else:
            measured = np.round(distance + error + nlos_total + gross, 3)
        forward = np.arange(n) % 2 == 0
        columns = {
            "time": time,
            "pair": np.full(n, pair),
            "from": np.where(forward, link.a, link.b),
            "to": np.where(forward, link.b, link.a),
            "range": measured,
            "sigma": np.full(n, params.uwb_declared_sigma_m),
        }
        if params.rssi:
            d = np.maximum(distance, 0.5)
            rssi = (
                -55.0
                - 20.0 * np.log10(d / 10.0)
                - 8.0 * (nlos_total > 0)
                + rng.normal(0.0, 1.5, size=n)
            )
            columns["rssi"] = np.round(rssi, 1)
        ranges.append({key: value[keep] for key, value in columns.items()})
        dists.append(
            {
                "time": time[keep],
                "pair": columns["pair"][keep],
                "distance": distance[keep],
                "error": (measured - distance)[keep],
            }
        )
        written = keep & gross_mask
        gross_rows.append(
            {"time": time[written], "pair": columns["pair"][written], "error": gross[written]}
        )
        for event, mask, added in nlos_added:
            used = mask & keep
            if not used.any():
                continue
            event_rows.append(
                {
                    "pair": pair,
                    "start": start_s + event.start_s,
                    "end": start_s + event.end_s,
                    "nominal_mean": event.mean_m,
                    "realized_mean": float(added[used].mean()),
                    "epochs": int(used.sum()),
                }
            )
    nlos = pd.DataFrame(
        event_rows, columns=["pair", "start", "end", "nominal_mean", "realized_mean", "epochs"]
    )
    nlos = nlos.sort_values(["start", "pair"], kind="stable").reset_index(drop=True)
    return RangeOutput(
        ranges=_sorted(ranges),
        distances=_sorted(dists),
        nlos_events=nlos,
        gross_errors=_sorted(gross_rows),
    )


def _sorted(parts: list[dict[str, np.ndarray]]) -> pd.DataFrame:
    """One table of the pairs' columns (in pair order), sorted by time then pair (stable)."""
    frame = pd.DataFrame({key: np.concatenate([p[key] for p in parts]) for key in parts[0]})
    return frame.sort_values(["time", "pair"], kind="stable").reset_index(drop=True)
