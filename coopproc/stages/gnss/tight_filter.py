"""The tightly coupled GPS/UWB robust Kalman filter of paper 002 (eq. 6-20), all platforms
in one time-ordered pass.

State of each platform with GPS observations and no IMU (session ENU frame; with an
IMU: paper 002's INS error states, :mod:`coopproc.stages.gnss.tight_ins`, through the
same :class:`CvTrack` methods):
``[e, n, u, v_e, v_n, v_u, c dt_r, c dt_r']`` - position, velocity (constant-velocity
model, white acceleration of PSD ``q_h`` horizontally, ``q_v`` vertically), receiver
clock bias and drift (eq. 6-7, a two-state clock with the TCXO figures h0 = 2e-19,
h-2 = 2e-20 of Brown & Hwang 2012 Table 9.1: S_b = c^2 h0 / 2, S_d = c^2 2 pi^2 h-2).

Updates, in time order over every platform's GPS epochs and the UWB range rows:

- a GPS epoch (eq. 9, 11): one pseudorange row and one Doppler row (range rate
  -lambda D) per satellite above the mask (:mod:`coopproc.gnss.tight`);
- a UWB range (eq. 10) to an anchor (its known position) or to another platform: that
  platform's current estimate predicted to the range time (its position covariance
  projected on the line of sight is added to the range variance), or, for a platform
  without GPS observations, its navigation file (with its sigma). Both ends of an
  inter-platform range are updated, each with the other's prior.

Robust factor (eq. 14-20): IGG-III (eq. 18) scales R by 1 / gamma, rows with gamma =
1e-30 are dropped. A UWB range's innovation is standardised by its predicted variance
diag(H C H^T + R) (eq. 19, unit sigma 1). A GPS epoch is re-weighted on its residuals
after the update, V - H dx, standardised by their variance R - H C+ H^T (Baarda's
w-test; a dropped row: R + H C+ H^T), iterated until the factors settle
(:func:`_epoch_update`). Innovations against the prediction would not do: with the clock
free at every epoch and a weak prediction every innovation looks small, the faulty one
included. Eq. (20)'s MAD unit sigma is not used for the epochs: with 5-10 satellites one
fault smears into every residual and the MAD grows with it (on the GEONET files it let
20 of 21 injected 20 m errors in); the filter's unit sigma is 1, i.e. the paper's
adaptive part is left out. ``robust = False`` is the standard Kalman filter.

The first GPS epoch of a platform starts its filter: position from its navigation file
(else the session origin) with 30 m sigma, clock bias and drift from the median
pseudorange and Doppler residuals.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from coopproc.estimation.kalman import kf_update
from coopproc.estimation.process_models import cv_transition
from coopproc.estimation.range_model import slant_ranges_units
from coopproc.estimation.robust import igg3_factor
from coopproc.gnss.ephemeris import SPEED_OF_LIGHT
from coopproc.gnss.tight import GnssEpochs, LocalFrame, epoch_model
from coopproc.model import FloatArray

__all__ = [
    "CvTrack",
    "RangeRows",
    "TightOptions",
    "TrackOutput",
    "clock_transition",
    "run_tight",
]

_H0, _H2 = 2e-19, 2e-20  # TCXO Allan-variance coefficients (Brown & Hwang Table 9.1)


def clock_transition(dt: float) -> tuple[FloatArray, FloatArray]:
    """F and Q of the receiver clock [bias; drift] (m, m/s) over ``dt``: the constant-
    velocity model of the drift's noise c^2 2 pi^2 h_-2 plus the bias's white noise
    c^2 h_0 / 2 (Brown & Hwang sec. 9.3, the TCXO of :data:`_H0`, :data:`_H2`)."""
    sb, sd = SPEED_OF_LIGHT**2 * _H0 / 2.0, SPEED_OF_LIGHT**2 * 2.0 * np.pi**2 * _H2
    f, q = cv_transition(dt, np.array([sd]))
    q[0, 0] = sb * dt + q[0, 0]
    return f, q


#: fewest rows of a GPS epoch for the residual test (fewer: the innovation test)
_EPOCH_MIN = 5
#: robust re-weighting iterations of a GPS epoch at most
_ITERATIONS = 6
#: a factor this small (eq. 18's 1e-30) drops the row
_REJECTED = 1e-29


@dataclass(frozen=True)
class TightOptions:
    """Figures of one filter run."""

    uwb: bool = True
    robust: bool = True
    k0: float = 3.0
    k1: float = 4.5
    mask_deg: float = 10.0
    q_h: float = 0.5
    q_v: float = 0.05
    doppler_sigma_mps: float = 0.1
    start_sigma_m: float = 30.0
    #: session time -> satellites kept at that epoch (highest elevations; None: all)
    keep: Callable[[float], int | None] = field(default=lambda t: None)
    #: (platform, epoch index) -> {prn: metres added to its pseudorange}
    gross: Mapping[tuple[str, int], Mapping[int, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class RangeRows:
    """UWB ranges in time order: ``a`` / ``b`` platform ids, range and sigma (m)."""

    time_s: FloatArray
    a: tuple[str, ...]
    b: tuple[str, ...]
    range_m: FloatArray
    sigma_m: FloatArray


@dataclass
class TrackOutput:
    """One platform's states after each of its updates (and at its range epochs)."""

    time_s: list[float] = field(default_factory=list)
    state: list[FloatArray] = field(default_factory=list)
    sigma: list[FloatArray] = field(default_factory=list)
    n_sat: list[int] = field(default_factory=list)
    #: roll, pitch, heading (deg, states.csv's convention) per row; empty without an INS
    att_deg: list[FloatArray] = field(default_factory=list)


class CvTrack:
    """One platform's constant-velocity filter (module docstring). The filter talks to a
    track only through the methods below, so :class:`coopproc.stages.gnss.tight_ins.InsTrack`
    (paper 002's INS error states) can stand in for it."""

    #: index of the receiver clock bias in x (the drift follows it)
    clock = 6

    def __init__(self, name: str, epochs: GnssEpochs, start_enu: FloatArray) -> None:
        self.name = name
        self.ep = epochs
        self.x = np.zeros(8)
        self.x[:3] = start_enu
        self.c = np.eye(8)
        self.t: float | None = None
        self.out = TrackOutput()
        self.last_nsat = 0

    def ready(self, t: float) -> bool:
        """Whether the filter can start at ``t``."""
        return True

    def begin(self, t: float, clock_m: float, drift_mps: float, opt: TightOptions) -> None:
        """Start at the first GPS epoch: clock from the median residuals, 30 m sigma."""
        self.x[6] = clock_m
        self.x[7] = drift_mps
        self.c = np.diag([opt.start_sigma_m**2] * 3 + [4.0] * 3 + [opt.start_sigma_m**2, 100.0])
        self.t = t

    def gnss_pos(self) -> FloatArray:
        """The GPS antenna (session ENU)."""
        return self.x[:3]

    def uwb_pos(self) -> FloatArray:
        """The UWB antenna (session ENU)."""
        return self.x[:3]

    def vel(self) -> FloatArray:
        return self.x[3:6]

    def pos_cov(self) -> FloatArray:
        return self.c[:3, :3]

    def h_code(self, los: FloatArray) -> FloatArray:
        """Pseudorange rows (module :mod:`coopproc.gnss.tight`)."""
        h = np.zeros((los.shape[0], 8))
        h[:, :3] = -los
        h[:, 6] = 1.0
        return h

    def h_rate(self, los: FloatArray) -> FloatArray:
        """Range-rate (Doppler) rows."""
        h = np.zeros((los.shape[0], 8))
        h[:, 3:6] = -los
        h[:, 7] = 1.0
        return h

    def h_range(self, u: FloatArray) -> FloatArray:
        """A UWB range row, ``u`` the unit vector from the other end."""
        h = np.zeros((1, 8))
        h[0, :3] = u
        return h

    def feedback(self) -> None:
        """After an update (a closed-loop error state feeds back here; none here)."""

    def predict(self, t: float, opt: TightOptions) -> None:
        if self.t is None:
            return
        dt = t - self.t
        if dt <= 0.0:
            return
        f = np.eye(8)
        q = np.zeros((8, 8))
        f[:6, :6], q[:6, :6] = cv_transition(dt, np.array([opt.q_h, opt.q_h, opt.q_v]))
        f[6:, 6:], q[6:, 6:] = clock_transition(dt)
        self.x = f @ self.x
        c = f @ self.c @ f.T + q
        self.c = 0.5 * (c + c.T)
        self.t = t

    def record(self, t: float) -> None:
        out = self.out
        if out.time_s and out.time_s[-1] == t:
            out.state[-1] = self.x.copy()
            out.sigma[-1] = np.sqrt(np.diag(self.c)[:6])
            out.n_sat[-1] = self.last_nsat
            return
        out.time_s.append(t)
        out.state.append(self.x.copy())
        out.sigma.append(np.sqrt(np.diag(self.c)[:6]))
        out.n_sat.append(self.last_nsat)


def _update(track: CvTrack, v: FloatArray, h: FloatArray, r: FloatArray, opt: TightOptions) -> None:
    """A range (one row): IGG-III on the innovation standardised by its predicted
    variance (unit sigma 1: the MAD of one innovation is the innovation itself)."""
    if opt.robust:
        d = np.einsum("ij,jk,ik->i", h, track.c, h) + r
        gamma = igg3_factor(v / np.sqrt(d), opt.k0, opt.k1)
        keep = gamma > _REJECTED
        if not keep.any():
            return
        track.x, track.c = kf_update(track.x, track.c, v[keep], h[keep], r[keep], gamma[keep])
    else:
        track.x, track.c = kf_update(track.x, track.c, v, h, r)


def _epoch_update(
    track: CvTrack, v: FloatArray, h: FloatArray, r: FloatArray, opt: TightOptions
) -> None:
    """A GPS epoch: IGG-III factors from the standardised residuals after the update
    (module docstring), iterated until they settle."""
    if not opt.robust or v.shape[0] < _EPOCH_MIN:
        _update(track, v, h, r, opt)
        return
    x0, c0 = track.x, track.c
    gamma = np.ones(v.shape[0])
    for _ in range(_ITERATIONS):
        keep = gamma > _REJECTED
        if keep.sum() < 1:
            return
        x1, c1 = kf_update(x0, c0, v[keep], h[keep], r[keep], gamma[keep])
        # residual variance R - H C+ H^T with the nominal R (Baarda's w-test; a row left
        # out: R + H C+ H^T)
        hch = np.einsum("ij,jk,ik->i", h, c1, h)
        q_v = np.where(keep, np.maximum(r - hch, 1e-3 * r), r + hch)
        new = igg3_factor((v - h @ (x1 - x0)) / np.sqrt(q_v), opt.k0, opt.k1)
        if np.allclose(new, gamma, rtol=1e-3, atol=1e-6):
            break
        gamma = new
    else:
        keep = gamma > _REJECTED
        x1, c1 = kf_update(x0, c0, v[keep], h[keep], r[keep], gamma[keep])
    track.x, track.c = x1, c1


def _gnss_epoch(track: CvTrack, k: int, frame: LocalFrame, opt: TightOptions) -> None:
    m = epoch_model(track.ep, k, frame, track.gnss_pos(), track.vel(), opt.mask_deg)
    n = m.prn.shape[0]
    keep_n = opt.keep(float(track.ep.time_s[k]))
    order = np.argsort(-m.el, kind="stable")
    take = order if keep_n is None else order[: max(keep_n, 0)]
    code = m.code_obs_m.copy()
    for prn, meters in opt.gross.get((track.name, k), {}).items():
        code[m.prn == prn] += meters
    take = np.sort(take)
    track.last_nsat = int(take.size)
    if n == 0 or take.size == 0:
        return
    los = m.los_enu[take]
    if track.t is None:  # start: the clock from the median residuals
        if not track.ready(float(track.ep.time_s[k])):
            return
        rate = m.rate_obs_mps[take] - m.rate_model_mps[take]
        track.begin(
            float(track.ep.time_s[k]),
            float(np.median(code[take] - m.code_model_m[take])),
            float(np.nanmedian(rate)) if np.isfinite(rate).any() else 0.0,
            opt,
        )
    ic = track.clock
    v_code = code[take] - (m.code_model_m[take] + track.x[ic])
    h_code = track.h_code(los)
    rate_ok = np.isfinite(m.rate_obs_mps[take])
    v_rate = (m.rate_obs_mps[take] - (m.rate_model_mps[take] + track.x[ic + 1]))[rate_ok]
    h_rate = track.h_rate(los[rate_ok])
    v = np.concatenate([v_code, v_rate])
    h = np.vstack([h_code, h_rate])
    r = np.concatenate([m.code_var_m2[take], np.full(v_rate.shape[0], opt.doppler_sigma_mps**2)])
    _epoch_update(track, v, h, r, opt)
    track.feedback()


def _range_update(
    track: CvTrack,
    other: FloatArray,
    other_cov: FloatArray,
    rng: float,
    sigma: float,
    opt: TightOptions,
) -> None:
    rho, u = slant_ranges_units(track.uwb_pos() - other)
    dist = float(rho)
    if dist < 1e-3:
        return
    r = np.array([sigma**2 + float(u @ other_cov @ u)])
    _update(track, np.array([rng - dist]), track.h_range(u), r, opt)
    track.feedback()


def run_tight(
    epochs: Mapping[str, GnssEpochs],
    starts: Mapping[str, FloatArray],
    frame: LocalFrame,
    ranges: RangeRows,
    fixed: Callable[[str, float], tuple[FloatArray, FloatArray] | None],
    opt: TightOptions,
    make_track: Callable[[str, GnssEpochs, FloatArray], CvTrack] = CvTrack,
) -> dict[str, TrackOutput]:
    """Run the filter of every platform of ``epochs`` over its GPS epochs and (``uwb``)
    the ``ranges``. ``fixed(id, t)``: the position (3,) and covariance (3, 3) of an anchor
    or of a platform without GPS at time t, or None when it has none. ``make_track``
    builds each platform's track (:class:`CvTrack`, or the INS one)."""
    tracks = {p: make_track(p, ep, starts[p]) for p, ep in epochs.items()}
    kinds: list[np.ndarray] = []
    for i, (_, ep) in enumerate(sorted(tracks.items())):
        n = len(ep.ep)
        kinds.append(np.column_stack([ep.ep.time_s, np.zeros(n), np.full(n, i), np.arange(n)]))
    names = sorted(tracks)
    if ranges.time_s.size:  # without UWB: only the epochs (predictions) of the ranges
        n = ranges.time_s.size
        kinds.append(np.column_stack([ranges.time_s, np.ones(n), np.zeros(n), np.arange(n)]))
    events = np.vstack(kinds) if kinds else np.empty((0, 4))
    events = events[np.lexsort((events[:, 1], events[:, 0]))]
    for t, kind, who, idx in events:
        if kind == 0.0:
            track = tracks[names[int(who)]]
            track.predict(float(t), opt)
            _gnss_epoch(track, int(idx), frame, opt)
            if track.t is not None:
                track.record(float(t))
            continue
        j = int(idx)
        a, b = ranges.a[j], ranges.b[j]
        ends = [tracks.get(a), tracks.get(b)]
        live = [tr for tr in ends if tr is not None and tr.t is not None]
        if not live:
            continue
        for tr in live:
            tr.predict(float(t), opt)
        # each end's prior, for the other end
        priors = {tr.name: (tr.uwb_pos().copy(), tr.pos_cov().copy()) for tr in live}
        for tr in live:
            other_id = b if tr.name == a else a
            there = priors.get(other_id) or fixed(other_id, float(t))
            if opt.uwb and there is not None:
                rng, sig = float(ranges.range_m[j]), float(ranges.sigma_m[j])
                _range_update(tr, there[0], there[1], rng, sig, opt)
            tr.record(float(t))
    return {p: tr.out for p, tr in tracks.items()}
