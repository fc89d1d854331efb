"""What the self-calibration estimated, against what the session declared.

Printed by ``coopproc run`` after the progress bar and written to run.json
(``calibration``): per pair the UWB noise the ranging filters used (white noise, innovation
spread behind gamma_max, DI growth) and the fusion's ranging sigma and post-fit bias; per
platform its dead reckoning against the cooperative solution and any drift inflation; the
fusion's notes.
"""

from __future__ import annotations

import math
from typing import Any

from coopproc.run.pipeline_output import PipelineOutput
from coopproc.stages.base import CalibrationWindows, RangeCalibration
from coopproc.stages.fusion.calibration_bias import bias_words
from coopproc.stages.fusion.dr_quality import (
    DRIFT_WINDOW_S,
    HEADING_WINDOW_S,
    MIN_TRAVEL_M,
    MIN_WINDOWS,
    DeadReckoningQuality,
)
from coopproc.stages.fusion.dr_states import dr_summary
from coopproc.stages.registry import nlos_primary

__all__ = ["calibration_facts", "calibration_lines"]

#: A pair's post-fit bias is printed when it is at least this fraction of its sigma ...
BIAS_FRACTION = 0.5
#: ... and at least this large (m).
BIAS_MIN_M = 0.05


def _num(value: float, digits: int = 4) -> float | None:
    return round(float(value), digits) if math.isfinite(value) else None


def _windows(local: CalibrationWindows | None) -> list[dict[str, Any]]:
    """The per-window calibration of a pair and method (ranging/local.py) for run.json."""
    if local is None:
        return []
    return [
        {
            "start": _num(float(local.starts_s[w]), 3),
            "white_sigma_m": _num(float(local.white_m[w])),
            "detect_sigma_m": _num(float(local.detect_m[w])),
            "di_growth_m2ps": _num(float(local.growth_m2ps[w]), 6),
            "gain": _num(float(local.gain[w]), 3),
            "mode": "ranges" if local.ranges_only[w] else "di",
            "estimated": bool(local.estimated[w]),
        }
        for w in range(local.white_m.shape[0])
    ]


def calibration_facts(output: PipelineOutput) -> dict[str, Any]:
    """The run.json ``calibration`` block."""
    pairs: dict[str, Any] = {}
    for (pair, method), cal in sorted(output.ranging_calibration.items()):
        pairs.setdefault(pair, {})[method] = {
            "declared_sigma_m": _num(cal.declared_sigma_m),
            "white_sigma_m": _num(cal.white_sigma_m),
            "detect_sigma_m": _num(cal.detect_sigma_m),
            "di_growth_m2ps": _num(cal.growth_m2ps, 6),
            "gain": _num(cal.gain, 3),
            "passthrough": cal.passthrough,
            "ranges_only_fraction": _num(cal.ranges_only_fraction, 4),
            "source": cal.source,
            "cp_source": cal.cp_source,
            "windows": _windows(cal.local),
        }
    fusion: dict[str, Any] = {}
    for method, fcal in sorted(output.fusion_calibration.items()):
        fusion[method] = {
            "pair_sigma_m": {p: _num(v) for p, v in sorted(fcal.pair_sigma_m.items())},
            "pair_bias_m": {p: _num(v) for p, v in sorted(fcal.pair_bias_m.items())},
            "platform_nis": {p: _num(v, 3) for p, v in sorted(fcal.platform_nis.items())},
            "drift_scale": {p: _num(v, 3) for p, v in sorted(fcal.drift_scale.items())},
        }
        if fcal.dr_jumps:  # the forward filter's (dr_faults.py)
            fusion[method]["dr_jumps"] = [
                {"platform": p, "time": _num(t, 3), "size_m": _num(size, 3)}
                for p, t, size in fcal.dr_jumps
            ]
    platforms = {
        p: {
            "declared_drift_mps": _num(q.declared_drift_mps),
            "drift_mps": _num(q.drift_mps),
            "heading_drift_deg_per_min": _num(q.heading_drift_dpm, 3),
            "scale": _num(q.scale),
        }
        for p, q in sorted(output.dr_quality.items())
    }
    for p, d in dr_summary(output.result.dr_states).items():  # the fusion's DR states
        facts: dict[str, Any] = platforms.setdefault(p, {})
        facts["fusion_dr_states"] = {  # dr_states.csv's convention: clockwise
            "heading_error_max_deg": _num(d.heading_error_max_deg, 3),
            "heading_rate_error_dph": _num(d.heading_rate_error_dph, 3),
            "heading_rate_sigma_dph": _num(d.heading_rate_sigma_dph, 3),
            "scale_error": _num(d.scale_error, 5),
            "scale_sigma": _num(d.scale_sigma, 5),
        }
    facts_of = {
        "ranging": pairs,
        "fusion": fusion,
        "dead_reckoning": platforms,
        "notes": list(output.notes),
    }
    if output.declared_sigma is not None:  # the declared [uwb] sigma checked
        facts_of["uwb_sigma"] = output.declared_sigma.facts()
    return facts_of


def _fmt(value: float, spec: str, unit: str = "") -> str:
    return f"{value:{spec}}{unit}" if math.isfinite(value) else "n/a"


def _dr_figures(q: DeadReckoningQuality, declared: str) -> str:
    """``dead reckoning drift 0.0025 m/s [0.0043], heading drift -0.04 deg/min, scale
    -0.13 %`` (``declared``: the bracket); a figure the data could not give says what it
    lacked (dr_quality.py's rules), not "n/a"."""
    if not math.isfinite(q.drift_mps):
        return (
            "dead reckoning not measured (fewer than 3 windows of "
            f"{DRIFT_WINDOW_S:g} s of fused solution){declared}"
        )
    text = f"dead reckoning drift {q.drift_mps:.4f} m/s{declared}"
    if math.isfinite(q.heading_drift_dpm) and math.isfinite(q.scale):
        return (
            f"{text}, heading drift {q.heading_drift_dpm:+.2f} deg/min, scale "
            f"{100.0 * q.scale:+.2f} %"
        )
    return (
        f"{text}, heading drift and scale not measured (fewer than {MIN_WINDOWS} windows "
        f"of {HEADING_WINDOW_S:g} s with {MIN_TRAVEL_M:g} m of travel or more)"
    )


def _declared_sigma(prior_m: float, output: PipelineOutput) -> str:
    """The bracket of a pair's UWB line: the declared sigma, and the figure that replaced
    it when the data contradicted it (run/declared_sigma.py)."""
    if not math.isfinite(prior_m):
        return ""
    checked = output.declared_sigma
    if checked is not None and checked.used_m is not None and prior_m == checked.used_m:
        return f" [{checked.declared_m:.3f} m, contradicted: {checked.used_m:.3f} m used]"
    return f" [{prior_m:.3f} m]"


def calibration_lines(output: PipelineOutput) -> list[str]:
    """A few lines per pair and platform for the terminal."""
    lines = ["self-calibration (declared values in brackets):"]
    observed = output.fusion_calibration.get("observed")
    # per pair, the primary (DI) filter's figures (else the first range method's that has any)
    by_pair: dict[str, RangeCalibration] = {}
    primary = nlos_primary()
    for (pair, method), cal in sorted(output.ranging_calibration.items()):
        if method in primary or pair not in by_pair:
            by_pair[pair] = cal
    fused_pairs = observed.pair_sigma_m if observed is not None else {}
    for pair in sorted(set(by_pair) | set(fused_pairs)):
        parts = []
        if pair in by_pair:
            cal = by_pair[pair]
            declared = _declared_sigma(cal.declared_sigma_m, output)
            text = (
                f"UWB white noise {cal.white_sigma_m:.3f} m{declared}, innovation "
                f"{cal.detect_sigma_m:.3f} m, DI growth {cal.growth_m2ps:.4f} m^2/s ({cal.source})"
            )
            fraction = cal.ranges_only_fraction
            if fraction > 0.0:
                text += (
                    f"; DI too poor to smooth in {100.0 * fraction:.0f} % of the time "
                    f"(gain {cal.gain:.2f}): ranges passed through there, NLOS from the "
                    "ranges alone"
                )
            parts.append(text)
        if observed is not None and pair in observed.pair_sigma_m:
            sigma = observed.pair_sigma_m[pair]
            text = f"fusion sigma {sigma:.3f} m"
            bias = observed.pair_bias_m.get(pair, math.nan)
            if math.isfinite(bias) and abs(bias) >= max(BIAS_FRACTION * sigma, BIAS_MIN_M):
                text += f", ranges read {bias_words(bias)}"
            parts.append(text)
        lines.append(f"  {pair}: " + "; ".join(parts))
    states = dr_summary(output.result.dr_states)
    for platform, q in sorted(output.dr_quality.items()):
        declared = f" [{q.declared_drift_mps:.4f}]" if math.isfinite(q.declared_drift_mps) else ""
        scale = observed.drift_scale.get(platform) if observed is not None else None
        inflated = f", fusion drift x{scale:.3g}" if scale else ""  # 0.03125: x0.0312, not x0.0
        if q.leader:  # its fix positions it in the fusion: e ~ 0 whatever it is
            lines.append(
                f"  {platform}: leader, dead reckoning not checked (the fusion takes its own "
                f"fix){declared}{inflated}"
            )
            continue
        lines.append(f"  {platform}: {_dr_figures(q, declared)}{inflated}")
        jumps = [] if observed is None else [s for p, _, s in observed.dr_jumps if p == platform]
        if jumps:  # the forward filter's jumps of its dead reckoning (dr_faults.py)
            lines.append(
                f"  {platform}: fusion found {len(jumps)} jump(s) of its dead reckoning, "
                f"{min(jumps):.2f}-{max(jumps):.2f} m (run.json calibration.fusion)"
            )
        d = states.get(platform)
        if d is not None:  # what the fusion's DR states estimated (dr_states.csv), in the
            # line above's units and sign (counter-clockwise; dr_states.csv is clockwise)
            lines.append(
                f"  {platform}: fusion DR states: heading drift "
                f"{_fmt(-d.heading_rate_error_dph / 60.0, '+.3f')} +- "
                f"{_fmt(d.heading_rate_sigma_dph / 60.0, '.3f')} deg/min, scale "
                f"{_fmt(100.0 * d.scale_error, '+.2f')} +- "
                f"{_fmt(100.0 * d.scale_sigma, '.2f', ' %')}, heading error up to "
                f"{_fmt(-d.heading_error_max_deg, '+.2f')} deg"
            )
    lines.extend(f"note: {note}" for note in output.notes)
    return lines
