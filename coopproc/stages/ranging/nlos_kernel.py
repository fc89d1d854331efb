"""The compiled per-epoch loop of the distance filter (paper 000 eq. (8)) with NLOS detection
(eq. (9)) and estimation (eq. (10)-(12)) over one pair's range epochs without restart gaps
(:func:`filter_kernel`, run per piece by :func:`coopproc.stages.ranging.nlos.filter_distance`).

State [D, I] (distance and DI), observations [measured range L_D, DI L_I]; w_D = 0. Each epoch:

1. predict ``D = D + I``; two transition conventions (``transition``):
   ``"aligned"`` (default): D_k = D_{k-1} + I_k, I_k = I_{k-1} + w_k, i.e. the process noise
   enters D and I alike (Q = q [[1, 1], [1, 1]]) and the DI observed at k moves D_k fully;
   ``"lagged"``: eq. (8) as printed, D_k = D_{k-1} + I_{k-1}, Q = diag(0, q), so D_k uses
   the DI one epoch late and the DI observed at k moves D_k only through P_DI.
2. update with L_I (the smoothed DI, variance from the DI smoothing filter).
3. residual r = L_D - D (paper 000 eq. (9): I_k - (L_D_k - D_{k-1}) up to sign);
   |r| > gamma_max = gamma_sigma * sigma starts an NLOS event.
4. range update with L_D (line of sight), with L_D - eps_hat (NLOS event after the
   estimation window), or none (estimation window: the distance is D', propagated by DI).

Events (DI method, ``one_shot = False``): eps_j = L_D_j - D'_j (eq. (10)), running mean over
the epochs with t_j - t_start < window_s (eq. (11)), held as the final estimate (eq. (12)).
Onset back-dating: when an event is detected at k, preceding epochs (within ``backdate_s``)
whose residual had the same sign and exceeded ``onset_fraction * gamma_max`` are taken as
the event's first epochs and the filter is rerun from before them (post-processing; their
ranges had pulled D towards the NLOS level). A false alarm is an event whose estimate at
the end of the window is below ``confirm_fraction * gamma_max`` (an outlier at the onset:
its flags are cleared, the window epochs stay predicted only), or whose ranges alone show
no step up of ``jump_fraction`` times the estimate at the onset (``range_jump``, see
:mod:`coopproc.stages.ranging.jump`: a dead-reckoning fault moved the DI-propagated
distance, not NLOS the ranges; its epochs are redone as line of sight, without a new
detection until the window's end).
End of an event: the raw residual is nearer 0 than eps_hat for ``end_confirm_s`` seconds
and at least ``end_min_epochs`` epochs; those epochs are not used (predict only) while
pending and are unflagged when the end is confirmed.

RN method (``one_shot = True``, paper 000 ref. [2]): eps estimated once, at detection, from
that epoch's residual, and held; no back-dating, no false-alarm rejection. An epoch that
breaks a pending end of >= end_min_epochs is not used (L - eps_hat would lock the hold on).

Adaptive sigma (paper 000 ref. [37], Mohamed & Schwarz): when the UWB sigma is unknown,
sigma'^2 = mean(r^2) over the last ``adaptive_n`` line-of-sight residuals (after the DI
update, winsorized at gamma_max), floored at ``min_sigma``: the windowed innovation
covariance C_v without subtracting H P- H^T (sigma' sets gamma_max, and the eq. (9)
residual includes the prediction error). Before ``adaptive_min_n`` residuals the initial
sigma is used (a robust MAD estimate from the range differences, see ranging.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from coopproc.model import FloatArray
from coopproc.stages.ranging.jump import (
    FIT_ADEQUACY,
    STEP_SIGNIFICANCE,
    range_jump,
    step_fit,
    steps_up,
)
from coopproc.stages.ranging.nlos_types import FilterSeries, FilterSettings

__all__ = ["filter_kernel"]


@njit(cache=True)
def filter_kernel(
    series: FilterSeries, settings: FilterSettings
) -> tuple[FloatArray, np.ndarray, FloatArray, np.ndarray, FloatArray, FloatArray, FloatArray]:
    """The loop over one piece (module docstring): distance, NLOS flag (int8), estimate,
    event index (-1: none), the running estimate in estimation windows, the sigma used
    and the eq. (9) residual, per epoch."""
    t, rng, di, di_var, sigma_known, detect_sigma, ranges_only, motion = series
    (
        sigma_init, gamma_sigma, window_s, aligned, accel, one_shot, backdate_s,
        onset_fraction, confirm_fraction, end_confirm_s, end_min_epochs, adaptive_n,
        adaptive_min_n, min_sigma, suspect_epochs, positive_only, max_event_s,
        jump_fraction, jump_window_s,
    ) = settings  # fmt: skip
    n = t.shape[0]
    out_d = np.full(n, np.nan)
    flag = np.zeros(n, dtype=np.int8)
    est_out = np.zeros(n)
    event = np.full(n, -1, dtype=np.int64)
    step_est = np.full(n, np.nan)
    sigma_out = np.full(n, np.nan)
    resid = np.full(n, np.nan)
    in_event = np.zeros(n, dtype=np.int8)  # epoch was ever processed inside an event
    s_d = np.zeros(n)
    s_i = np.zeros(n)
    s_pdd = np.zeros(n)
    s_pdi = np.zeros(n)
    s_pii = np.zeros(n)
    ring_v2 = np.zeros(max(adaptive_n, 1))
    ring_count = 0
    ring_pos = 0
    sum_v2 = 0.0
    if n == 0:
        return out_d, flag, est_out, event, step_est, sigma_out, resid
    adaptive = sigma_known[0] <= 0.0
    sigma = sigma_init if adaptive else sigma_known[0]
    d = rng[0]
    for j0 in range(n):  # a rejected (NaN) first range: start on the first kept one
        if np.isfinite(rng[j0]):
            d = rng[j0]
            break
    i = 0.0
    p_dd = sigma * sigma
    p_di = 0.0
    p_ii = 1.0
    out_d[0] = d
    sigma_out[0] = sigma
    s_d[0], s_i[0], s_pdd[0], s_pdi[0], s_pii[0] = d, i, p_dd, p_di, p_ii
    mode = 0  # 0 line of sight, 1 estimation window, 2 holding the estimate
    n_events = 0
    ev_start = 0
    ev_t0 = 0.0
    eps_sum = 0.0
    eps_n = 0
    est = 0.0
    pend_n = 0
    pend_start = 0
    pend_t0 = 0.0
    n_suspect = 0
    suspect_sign = 0.0
    quiet_until = -1
    # int64, not the literal 1: a literal first type compiles steps_up and range_jump
    # twice (for Literal[int](1), then for int64) on the first run
    k = int(np.int64(1))
    while k < n:
        dt = t[k] - t[k - 1]
        # predict, paper 000 eq. (8) with w_D = 0 (a second range at the same time is a
        # second observation of the same distance: no prediction, no DI)
        if dt > 1e-9:
            q = (accel * dt * dt) ** 2
            d = d + i
            if aligned:
                p_dd = p_dd + 2.0 * p_di + p_ii + q
                p_di = p_di + p_ii + q
            else:
                p_dd = p_dd + 2.0 * p_di + p_ii
                p_di = p_di + p_ii
            p_ii = p_ii + q
        # DI observation L_I (none between two ranges at one time: no interval)
        z_i = di[k]
        if np.isfinite(z_i) and dt > 1e-9:
            s_var = p_ii + di_var[k]
            k_d = p_di / s_var
            k_i = p_ii / s_var
            v = z_i - i
            d += k_d * v
            i += k_i * v
            p_dd, p_di, p_ii = p_dd - k_d * p_di, p_di - k_d * p_ii, p_ii - k_i * p_ii
        if not adaptive:
            sigma = sigma_known[k]  # the calibration window's (local.py)
        else:
            sigma = sigma_init
            if ring_count >= adaptive_min_n:
                # Mohamed & Schwarz's windowed innovation covariance C_v. Their R = C_v -
                # H P- H^T is not subtracted: the eq. (9) residual carries the prediction
                # error too, and sigma' sets gamma_max (measured: fewer false flags).
                r_hat = sum_v2 / ring_count
                sigma = np.sqrt(max(r_hat, min_sigma * min_sigma))
        if not np.isfinite(rng[k]):
            # a rejected range (gross outlier, outliers.py): predicted only, no detection;
            # inside an event the epoch keeps the event's flag and estimate
            if mode != 0:
                in_event[k] = 1
                flag[k] = 1
                event[k] = n_events
                est_out[k] = est
            out_d[k] = d
            sigma_out[k] = sigma
            s_d[k], s_i[k], s_pdd[k], s_pdi[k], s_pii[k] = d, i, p_dd, p_di, p_ii
            k += 1
            continue
        r = rng[k] - d  # paper 000, eq. (9) residual (D' = d, eq. (10))
        resid[k] = r
        gamma = gamma_sigma * (detect_sigma[k] if detect_sigma[k] > 0.0 else sigma)
        use = 0  # 0 no range update, 1 raw range, 2 range - eps_hat
        done = False
        if mode == 0 and adaptive:
            # every line-of-sight innovation, winsorized at gamma_max (excluding the
            # suspects would truncate the sample and shrink the estimate)
            v2 = min(r * r, gamma * gamma)
            if ring_count == adaptive_n:
                sum_v2 -= ring_v2[ring_pos]
            else:
                ring_count += 1
            ring_v2[ring_pos] = v2
            sum_v2 += v2
            ring_pos = (ring_pos + 1) % adaptive_n
        if mode == 0 and k <= quiet_until:
            n_suspect = 0
            use = 1
            done = True
        elif mode == 0:
            stepped = True
            if one_shot and ranges_only[k] != 0:
                # RN in a ranges-only window: the reference method has no prediction to
                # detect against (its relative velocity is the dead reckoning's); the
                # ranges pass through (real `plaza2`: a ranges-only step test held a
                # 4 m "event" for 18 s on b5-robot)
                stepped = False
            elif abs(r) > onset_fraction * gamma and (one_shot or suspect_epochs > 0):
                stepped = steps_up(t, rng, k, r, jump_fraction, jump_window_s)
            if not stepped:
                # a residual without a step in the ranges: the DI moved, not the range
                # (one-shot RN detections and suspects; the DI method tests its events
                # at the end of the estimation window); used as line of sight
                n_suspect = 0
                use = 1
                done = True
            elif abs(r) > gamma:
                start = k
                if backdate_s > 0.0:
                    while (
                        start - 1 >= 1
                        and in_event[start - 1] == 0
                        and t[k] - t[start - 1] <= backdate_s
                        and r * resid[start - 1] > 0.0
                        and abs(resid[start - 1]) > onset_fraction * gamma
                    ):
                        start -= 1
                mode = 1
                ev_start = start
                ev_t0 = t[start]
                eps_sum = 0.0
                eps_n = 0
                if start < k:
                    j = start - 1
                    d, i, p_dd, p_di, p_ii = s_d[j], s_i[j], s_pdd[j], s_pdi[j], s_pii[j]
                    k = start
                    continue
            elif abs(r) > onset_fraction * gamma and suspect_epochs > 0:
                # suspect: not used; enough suspects in a row are an event (back-dated)
                if n_suspect > 0 and r * suspect_sign > 0.0:
                    n_suspect += 1
                else:
                    n_suspect = 1
                suspect_sign = r
                if n_suspect >= suspect_epochs:
                    start = k
                    while start - 1 >= 1 and k - start + 1 < n_suspect:
                        start -= 1
                    mode = 1
                    ev_start = start
                    ev_t0 = t[start]
                    eps_sum = 0.0
                    eps_n = 0
                    n_suspect = 0
                    j = start - 1
                    d, i, p_dd, p_di, p_ii = s_d[j], s_i[j], s_pdd[j], s_pdi[j], s_pii[j]
                    k = start
                    continue
                done = True
            else:
                n_suspect = 0
                use = 1
                done = True
        if mode == 1 and not done:
            if t[k] - ev_t0 >= window_s - 1e-9 and eps_n > 0:
                stepless = False
                if ranges_only[ev_start] != 0 and not one_shot:
                    # no DI in this calibration window (local.py): D' was a constant-
                    # velocity prediction of the ranges themselves, so the estimate is
                    # the ranges' own step at the onset (step_fit on the ranges less the
                    # dead-reckoning motion, whose drift over the fit the quadratic
                    # absorbs), not eq. (11)'s mean; the event stands only if that step
                    # is significant
                    jump, jump_se, fit_sd = step_fit(t, rng, motion, ev_start, jump_window_s)
                    if (
                        np.isfinite(jump)
                        and jump >= STEP_SIGNIFICANCE * jump_se
                        and fit_sd <= FIT_ADEQUACY * sigma
                    ):
                        est = jump
                    else:
                        stepless = True
                elif not one_shot and jump_fraction > 0.0:
                    jump, _ = range_jump(t, rng, ev_start, jump_window_s)
                    stepless = np.isfinite(jump) and jump < jump_fraction * est
                small = abs(est) < confirm_fraction * gamma
                stepless = stepless and not small
                if not one_shot and (small or stepless):
                    # false alarm: clear the event
                    for j in range(ev_start, k):
                        flag[j] = 0
                        event[j] = -1
                        est_out[j] = 0.0
                        step_est[j] = np.nan
                    mode = 0
                    est = 0.0
                    in_event[k] = 1
                    if not stepless:
                        # a small estimate: the onset was an outlier; the window epochs
                        # stay predicted only, this one is redone as line of sight
                        j = k - 1
                        d, i, p_dd, p_di, p_ii = s_d[j], s_i[j], s_pdd[j], s_pdi[j], s_pii[j]
                        continue
                    # no step in the ranges: a DI fault; the ranges of the window are good,
                    # redo its epochs as line of sight without a new detection
                    quiet_until = k
                    j = ev_start - 1
                    d, i, p_dd, p_di, p_ii = s_d[j], s_i[j], s_pdd[j], s_pdi[j], s_pii[j]
                    k = ev_start
                    continue
                if positive_only and est < 0.0:
                    # NLOS only lengthens ranges: a negative "event" means the filtered
                    # distance had absorbed an error; re-anchor it on the ranges.
                    for j in range(ev_start, k):
                        flag[j] = 0
                        event[j] = -1
                        est_out[j] = 0.0
                        step_est[j] = np.nan
                        out_d[j] += est
                    d += est
                    r -= est
                    est = 0.0
                    mode = 0
                    use = 1
                    done = True
                else:
                    mode = 2
                    pend_n = 0
            else:
                eps = r  # paper 000, eq. (10): eps = L_D - D'
                done = True
                if one_shot and positive_only and eps < 0.0:
                    # negative one-shot estimate: re-anchor on the ranges (see above)
                    d += eps
                    r = 0.0
                    mode = 0
                    use = 1
                else:
                    if one_shot:
                        est = eps
                        eps_n = 1
                        mode = 2
                        pend_n = 0
                    else:
                        eps_sum += eps
                        eps_n += 1
                        est = eps_sum / eps_n  # paper 000, eq. (11); (12) at the window end
                    step_est[k] = est
                    flag[k] = 1
                    event[k] = n_events
                    est_out[k] = est
        if mode == 2 and not done and t[k] - ev_t0 > max_event_s:
            # too long to be an obstruction: end the event, re-anchor on the ranges
            d += est
            r -= est
            est = 0.0
            mode = 0
            n_events += 1
            use = 1
            done = True
        if mode == 2 and not done:
            if abs(r) < abs(r - est):
                if pend_n == 0:
                    pend_start = k
                    pend_t0 = t[k]
                pend_n += 1
                if pend_n >= end_min_epochs and t[k] - pend_t0 >= end_confirm_s:
                    for j in range(pend_start, k):
                        flag[j] = 0
                        event[j] = -1
                        est_out[j] = 0.0
                    mode = 0
                    n_events += 1
                    pend_n = 0
                    est = 0.0
                    use = 1
                else:
                    flag[k] = 1
                    event[k] = n_events
                    est_out[k] = est
            else:
                use = 0 if one_shot and pend_n >= end_min_epochs else 2
                pend_n = 0
                flag[k] = 1
                event[k] = n_events
                est_out[k] = est
        if mode != 0:
            in_event[k] = 1
        if use > 0:
            r2 = sigma * sigma
            z = rng[k] - est if use == 2 else rng[k]
            s_var = p_dd + r2
            k_d = p_dd / s_var
            k_i = p_di / s_var
            v = z - d
            d += k_d * v
            i += k_i * v
            p_dd, p_di, p_ii = p_dd - k_d * p_dd, p_di - k_d * p_di, p_ii - k_i * p_di
        out_d[k] = d
        sigma_out[k] = sigma
        s_d[k], s_i[k], s_pdd[k], s_pdi[k], s_pii[k] = d, i, p_dd, p_di, p_ii
        k += 1
    if mode == 1 and not one_shot and eps_n > 0 and abs(est) < confirm_fraction * gamma:
        for j in range(ev_start, n):
            flag[j] = 0
            event[j] = -1
            est_out[j] = 0.0
            step_est[j] = np.nan
    return out_d, flag, est_out, event, step_est, sigma_out, resid
