"""Bounds on the UWB ranging sigma from the ranges and the dead reckoning alone.

A declared ``[uwb] sigma`` cannot be judged by the fusion's post-fit residuals: the fusion
fits its positions to these very ranges ("self-calibration must not judge data with
itself"), and where the dead reckoning is weak its residual RMS is far below the ranges'
error (``plaza2``: 0.023-0.030 m against a declared 0.511 m). The two figures here use no
fused position. Per pair, with ``I_k`` the distance increments of the platforms' own
navigation (anchors at their declared position) and ``z_k = L_k - sum_{j<=k} I_j`` the
ranges less the distance change the dead reckoning accounts for
(:mod:`coopproc.stages.ranging.calibration`):

- **the white noise** sigma_w, the smaller of ``white_sigma`` (calibration.py) of the
  ranges alone and of z (each range against the line through its two neighbours,
  robust; the ranging stage's estimate, local.py step 1). A range error has at least this
  spread: its white part alone has it. A **lower bound** of the ranges' sigma.
- **the long-lag spread** sigma_long = max over tau in :data:`LONG_LAGS_S` of
  sqrt(V(tau) / 2), V(tau) the robust variance of z(t + tau) - z(t) (the structure
  function of calibration.py). For lags past the correlation time of the range error e,
  V = 2 var(e) + the variance of the dead reckoning's error over tau, so sqrt(V / 2) is at
  least the spread of e, and the largest of three lags is safer still. An **upper bound**
  of the ranges' sigma apart from what no difference sees: a constant bias per pair, and
  errors slower than 60 s. Only pairs whose two platforms have navigation (or a declared
  anchor position) give it; a pair with a tag (no navigation) has its motion in z.

The session's figures are the medians over its pairs (:class:`SigmaBounds`);
:mod:`coopproc.run.declared_sigma` compares the declared sigma with them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coopproc.model import Session
from coopproc.names import pair_members
from coopproc.stages.ranging.calibration import _lagged_variance, accumulated, white_sigma
from coopproc.stages.ranging.di import range_increments
from coopproc.stages.ranging.table import pair_columns, platform_positions

__all__ = ["LONG_LAGS_S", "WHITE_MAX_INTERVAL_S", "SigmaBounds", "sigma_bounds"]

#: Lags of the long-lag spread, seconds: beyond the few seconds over which the white
#: noise and the short multipath of a moving platform decorrelate, short enough that the
#: dead reckoning's error over the lag stays small beside the ranges' (sample_logs'
#: 0.0043 m/s drift adds ~0.03 m over 60 s); a lag without 20 differences is left out
#: (TIERS, 64 s, has no 60 s figure on most pairs).
LONG_LAGS_S = (10.0, 30.0, 60.0)


#: A pair with an end without navigation (a tag) gives the white-noise figure only when
#: its ranges are at most this far apart (median, seconds): the line through a range's two
#: neighbours then follows the tag's motion on most triplets (the estimate is robust: a
#: walking tag goes straight between most of its 1 Hz ranges, and its turns are a minority
#: of them). The simulator's ``quadrotor`` (one range per anchor every 3 s, a drone that
#: never flies straight for long) read 1.16 m of "white noise" under a 0.15 m declared
#: sigma without it, and the check replaced the sigma by that.
WHITE_MAX_INTERVAL_S = 1.0


@dataclass(frozen=True)
class SigmaBounds:
    """What the ranges and the dead reckoning say about the ranging sigma (NaN: no pair
    gave the figure)."""

    white_m: float  # median over the pairs of sigma_w: a lower bound
    long_m: float  # median over the pairs with navigation of sigma_long: an upper bound
    pairs: int  # pairs behind white_m
    long_pairs: int  # pairs behind long_m


def _has_track(session: Session, platform: str) -> bool:
    info = session.platforms.get(platform)
    fixed = info is not None and info.role == "anchor" and info.position_enu_m is not None
    return fixed or platform in session.nav


def _long_spread(time_s: np.ndarray, z: np.ndarray) -> float:
    spreads = []
    for lag in LONG_LAGS_S:
        variance = _lagged_variance(time_s, z, lag)[0]
        if np.isfinite(variance):
            spreads.append(float(np.sqrt(0.5 * variance)))
    return max(spreads) if spreads else float("nan")


def sigma_bounds(session: Session) -> SigmaBounds:
    """The session's :class:`SigmaBounds` (module docstring)."""
    white, long = [], []
    for pair in session.ranges.pairs:
        t, range_m = pair_columns(session, pair)
        keep = np.isfinite(t) & np.isfinite(range_m)
        t, range_m = t[keep], range_m[keep]
        a, b = pair_members(pair)
        alone = white_sigma(t, range_m)
        if _has_track(session, a) and _has_track(session, b) and t.shape[0]:
            pos_a, pos_b = (
                platform_positions(session, session.nav, p, t, "navigation", True) for p in (a, b)
            )
            z = range_m - accumulated(range_increments(pos_a, pos_b))
            sigma_w = float(np.fmin(alone, white_sigma(t, z)))
            spread = _long_spread(t, z)
            if np.isfinite(spread):
                long.append(spread)
        elif t.shape[0] > 2 and float(np.median(np.diff(t))) <= WHITE_MAX_INTERVAL_S:
            sigma_w = alone  # a tag's own motion bends the ranges little between neighbours
        else:
            sigma_w = float("nan")  # sparse ranges of a moving tag: its motion, not noise
        if np.isfinite(sigma_w):
            white.append(sigma_w)
    return SigmaBounds(
        white_m=float(np.median(white)) if white else float("nan"),
        long_m=float(np.median(long)) if long else float("nan"),
        pairs=len(white),
        long_pairs=len(long),
    )
