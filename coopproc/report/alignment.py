"""Aligning an estimated trajectory onto its reference before statistics (as evo does).

Every alignment is a closed-form least-squares fit of a transform ``y ~ s R x + t`` that
maps the estimated positions ``x`` onto the reference positions ``y`` at the same epochs
(positions only: ``positions.csv`` carries no attitude):

| kind | fitted | degrees of freedom |
|---|---|---|
| ``none`` | nothing (identity) | 0 |
| ``se2`` | rotation about the up axis (yaw) + east/north translation; up untouched | 3 |
| ``yaw`` | rotation about the up axis (yaw) + east/north/up translation | 4 |
| ``se3`` | rotation + translation (Umeyama 1991 without scale) | 6 |
| ``sim3`` | rotation + translation + scale (Umeyama 1991) | 7 |

``yaw`` is the "posyaw" alignment of visual-inertial odometry evaluation (Zhang and
Scaramuzza, IROS 2018): with a gravity-levelled estimate only the heading and the
position are unobservable, so only those are fitted; it needs positions only (a GNSS or
motion-capture reference without attitude). ``se2`` is the same rotation with a purely
horizontal shift, for a planar evaluation where the heights are not to be adjusted.

Umeyama, S. (1991), "Least-squares estimation of transformation parameters between two
point patterns", IEEE Trans. PAMI 13(4), 376-380: eq. (34)-(43), implemented as in evo
(``evo.core.geometry.umeyama_alignment``). The yaw-only fit is the same problem restricted
to rotations about the up axis, whose minimiser is
``yaw = atan2(sum(x_e y_n - x_n y_e), sum(x_e y_e + x_n y_n))`` over the centred points.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

from coopproc.model import FloatArray

__all__ = ["ALIGNMENTS", "Alignment", "AlignmentError", "Transform", "fit_alignment", "umeyama"]

Alignment = Literal["none", "se2", "yaw", "se3", "sim3"]
#: Every alignment, in the order tables list them.
ALIGNMENTS: tuple[Alignment, ...] = ("none", "se2", "yaw", "se3", "sim3")
#: Fewest epochs each alignment needs (a 3-D rotation needs points off one line).
_MIN_EPOCHS = {"none": 1, "se2": 2, "yaw": 2, "se3": 3, "sim3": 3}


class AlignmentError(ValueError):
    """The epochs do not determine the transform (too few, all on one point or line)."""


@dataclass(frozen=True)
class Transform:
    """``y = scale * rotation @ x + translation`` (ENU, metres)."""

    rotation: FloatArray
    translation: FloatArray
    scale: float = 1.0

    @classmethod
    def identity(cls) -> Transform:
        return cls(np.eye(3), np.zeros(3), 1.0)

    def apply(self, points: FloatArray) -> FloatArray:
        """The (n, 3) ``points`` transformed."""
        p = np.asarray(points, dtype=np.float64)
        return self.scale * p @ self.rotation.T + self.translation

    def euler_deg(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) of the rotation in degrees, intrinsic z-y'-x'' (yaw about up,
        then pitch, then roll; scipy ``as_euler("ZYX")``); yaw counter-clockwise seen from
        above (from east towards north)."""
        yaw, pitch, roll = Rotation.from_matrix(self.rotation).as_euler("ZYX", degrees=True)
        return float(roll), float(pitch), float(yaw)


def umeyama(x: FloatArray, y: FloatArray, *, with_scale: bool = False) -> Transform:
    """Least-squares ``y ~ c R x + t`` for two (n, 3) point sets (Umeyama 1991).

    Raises :class:`AlignmentError` when the covariance has rank below 2 (points on a line:
    the rotation about it is undetermined).
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n, m = x.shape
    mean_x, mean_y = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mean_x, y - mean_y
    var_x = float(np.sum(xc * xc)) / n  # eq. (36)
    cov = yc.T @ xc / n  # eq. (38)
    u, d, vt = np.linalg.svd(cov)
    if np.count_nonzero(d > np.finfo(np.float64).eps * max(1.0, float(d[0]))) < m - 1:
        raise AlignmentError("the points lie on a line: the rotation is undetermined")
    s = np.eye(m)
    if np.linalg.det(u) * np.linalg.det(vt) < 0.0:  # eq. (43): a rotation, not a reflection
        s[m - 1, m - 1] = -1.0
    r = u @ s @ vt  # eq. (40)
    c = float(np.trace(np.diag(d) @ s)) / var_x if with_scale else 1.0  # eq. (42)
    t = mean_y - c * r @ mean_x  # eq. (41)
    return Transform(r, t, c)


def _fit_yaw(x: FloatArray, y: FloatArray, *, vertical: bool) -> Transform:
    """Rotation about up (+ translation, horizontal only unless ``vertical``)."""
    mean_x, mean_y = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mean_x, y - mean_y
    sin = float(np.sum(xc[:, 0] * yc[:, 1] - xc[:, 1] * yc[:, 0]))
    cos = float(np.sum(xc[:, 0] * yc[:, 0] + xc[:, 1] * yc[:, 1]))
    if sin == 0.0 and cos == 0.0:
        raise AlignmentError("the horizontal positions have no spread: the yaw is undetermined")
    r = Rotation.from_euler("z", np.arctan2(sin, cos)).as_matrix()
    t = mean_y - r @ mean_x
    if not vertical:
        t[2] = 0.0
    return Transform(r, t, 1.0)


def fit_alignment(kind: str, est: FloatArray, ref: FloatArray) -> Transform:
    """The transform of alignment ``kind`` (see the module table) taking ``est`` onto ``ref``,
    both (n, 3) ENU positions at the same epochs.

    Raises :class:`AlignmentError` when the epochs do not determine it, ValueError for an
    unknown ``kind``.
    """
    if kind not in _MIN_EPOCHS:
        raise ValueError(f"unknown alignment {kind!r}; expected one of {', '.join(ALIGNMENTS)}")
    x = np.asarray(est, dtype=np.float64)
    y = np.asarray(ref, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 2 or x.shape[1] != 3:
        raise ValueError("expected two (n, 3) arrays of positions")
    if kind == "none":
        return Transform.identity()
    if x.shape[0] < _MIN_EPOCHS[kind]:
        raise AlignmentError(f"{kind} needs at least {_MIN_EPOCHS[kind]} epochs")
    if kind in ("se2", "yaw"):
        return _fit_yaw(x, y, vertical=kind == "yaw")
    if not np.any(x != x[0]):
        raise AlignmentError("the estimated positions have no spread")
    return umeyama(x, y, with_scale=kind == "sim3")
