"""The declared UWB sigma checked against the data, not only used (issue 32 part 3).

``[uwb] sigma`` (session.toml) is the prior of the ranging stage's noise figures, the
fusion's ranging sigma of every row without its own ``sigma`` and the sigma the true NLOS
ranges are labelled against. A figure wrong by 10 x either way is used silently otherwise.
The fusion's post-fit RMS cannot judge it (it fits the ranges it judges), so the check
uses two figures that contain no fused position
(:mod:`coopproc.stages.ranging.noise_bounds`): the ranges' white noise, which the declared
sigma cannot be below, and their long-lag spread against the dead reckoning, which it
cannot be far above. The declared sigma is contradicted when

    declared < white / SIGMA_FACTOR    (too small: the white noise alone is larger)
    declared > SIGMA_FACTOR * long     (too large: no lag shows an error that large)

and the bound it breaks replaces it for the whole run (the nearest figure the data allow),
with one note saying both, unless ``[calibration] trust_declared = true`` (the note then
says it was kept). A session without the long-lag figure (every pair has a tag without
navigation) is checked on the small side only.

Why 3 (declared / white and declared / long on the sessions it was chosen on, every one
kept): ``sample_logs`` 1.81 / 1.20; real ``tiers`` 4.00 / 0.67; ``tuc`` 1.38 / 0.076;
``plaza2`` 0.91 / 0.018; ``miluv1`` 0.65 / 0.38; ``hanyang_los`` 25.6 / none (a tag
without navigation). The declared figures of the real sessions are the spread of range
minus true distance (their READMEs), which the two bounds bracket. The white ratio reaches
4.0 (TIERS) and 25.6 (hanyang_los: 8 mm of white noise under 0.206 m of slow,
position-dependent error), so a large declared / white says nothing: only the small side
uses it, where the lowest real ratio is 0.65 (miluv1, a drone ranging every 1.3 s, whose
white figure holds some of its motion), 2 x above 1 / 3. On the large side the highest is
1.20 (sample_logs), 2.5 x below 3. ``sample_logs`` with its 0.15 m declared 10 x too small
gives 0.18 (1 / 5.5) and 10 x too large 12.0: both caught (tests/test_declared_sigma.py).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from coopproc.model import Session
from coopproc.stages.ranging.noise_bounds import SigmaBounds, sigma_bounds

__all__ = ["SIGMA_FACTOR", "DeclaredSigma", "check_declared_sigma", "with_sigma"]

#: A declared sigma below 1 / this of the white noise, or above this times the long-lag
#: spread, is contradicted by the data (module docstring).
SIGMA_FACTOR = 3.0


@dataclass(frozen=True)
class DeclaredSigma:
    """The check of a declared ``[uwb] sigma`` (m)."""

    declared_m: float
    bounds: SigmaBounds
    #: the figure that replaces the declared one; None: kept (consistent, or trusted)
    used_m: float | None
    #: "small" / "large" when the data contradict the declared figure, else None
    contradicted: str | None
    note: str | None

    def facts(self) -> dict[str, object]:
        """The run.json ``calibration.uwb_sigma`` block."""

        def num(value: float) -> float | None:
            return round(value, 4) if math.isfinite(value) else None

        return {
            "declared_m": num(self.declared_m),
            "white_m": num(self.bounds.white_m),
            "long_lag_m": num(self.bounds.long_m),
            "factor": SIGMA_FACTOR,
            "contradicted": self.contradicted,
            "used_m": num(self.used_m if self.used_m is not None else self.declared_m),
        }


def _judged(declared: float, bounds: SigmaBounds) -> tuple[str, float, str] | None:
    """("small" / "large", the bound it breaks, the sentence) or None when consistent."""
    white, long = bounds.white_m, bounds.long_m
    if math.isfinite(white) and declared * SIGMA_FACTOR < white:
        return (
            "small",
            white,
            f"the declared [uwb] sigma {declared:.3f} m is 1 / {white / declared:.1f} of "
            f"the white noise of the ranges ({white:.3f} m, median of {bounds.pairs} pairs, "
            f"from each range against its neighbours; contradicted beyond "
            f"{SIGMA_FACTOR:g} x)",
        )
    if math.isfinite(long) and declared > SIGMA_FACTOR * long:
        return (
            "large",
            long,
            f"the declared [uwb] sigma {declared:.3f} m is {declared / long:.1f} x the "
            f"largest spread of the ranges against the dead reckoning over 10-60 s "
            f"({long:.3f} m, median of {bounds.long_pairs} pairs; contradicted beyond "
            f"{SIGMA_FACTOR:g} x)",
        )
    return None


def check_declared_sigma(session: Session) -> DeclaredSigma | None:
    """The check of ``session``'s ``[uwb] sigma`` (None when none is declared)."""
    declared = session.config.uwb_sigma_m
    if declared is None or not (math.isfinite(declared) and declared > 0):
        return None
    bounds = sigma_bounds(session)
    judged = _judged(float(declared), bounds)
    if judged is None:
        return DeclaredSigma(float(declared), bounds, None, None, None)
    side, bound, said = judged
    if session.config.trust_declared:
        note = f"{said}: kept as declared ([calibration] trust_declared = true)"
        return DeclaredSigma(float(declared), bounds, None, side, note)
    note = (
        f"{said}: {bound:.3f} m used instead ([calibration] trust_declared = true keeps "
        "the declared figure)"
    )
    return DeclaredSigma(float(declared), bounds, bound, side, note)


def with_sigma(session: Session, checked: DeclaredSigma | None) -> Session:
    """``session`` with its ``[uwb] sigma`` replaced where ``checked`` replaces it."""
    if checked is None or checked.used_m is None:
        return session
    config = dataclasses.replace(session.config, uwb_sigma_m=checked.used_m)
    return dataclasses.replace(session, config=config)
