"""Closed driving paths: polygons with rounded corners, evaluated by arc length.

A :class:`LoopPath` is a densely sampled closed curve (east, north in metres) with its
cumulative arc length; positions, tangents and normals at any arc length ``s`` (taken
modulo the loop length) come from linear interpolation of that sampling, which is far
finer (<= 5 cm) than any sensor error the simulator adds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from coopproc.model import FloatArray

__all__ = ["LoopPath", "rounded_polygon", "rounded_rectangle"]

_STEP_M = 0.05


@dataclass(frozen=True, eq=False)
class LoopPath:
    """A closed curve sampled at ``s_m`` (cumulative arc length, first 0) -> ``xy_m`` (n, 2)."""

    s_m: FloatArray
    xy_m: FloatArray

    @property
    def length_m(self) -> float:
        return float(self.s_m[-1])

    def position(self, s_m: FloatArray) -> FloatArray:
        """(n, 2) east/north at arc lengths ``s_m`` (modulo the loop length)."""
        s = np.mod(s_m, self.length_m)
        return np.column_stack(
            (np.interp(s, self.s_m, self.xy_m[:, 0]), np.interp(s, self.s_m, self.xy_m[:, 1]))
        )

    def tangent(self, s_m: FloatArray) -> FloatArray:
        """(n, 2) unit tangent (direction of travel) at ``s_m``."""
        d = self.position(s_m + _STEP_M) - self.position(s_m - _STEP_M)
        return d / np.hypot(d[:, 0], d[:, 1])[:, None]

    def left_normal(self, s_m: FloatArray) -> FloatArray:
        """(n, 2) unit normal pointing left of the direction of travel."""
        t = self.tangent(s_m)
        return np.column_stack((-t[:, 1], t[:, 0]))


def rounded_polygon(corners_m: Sequence[tuple[float, float]], radius_m: float) -> LoopPath:
    """A closed path through the polygon ``corners_m`` with each corner filleted by an arc.

    The fillet at corner P with incoming unit direction u1 and outgoing u2 (turn angle
    alpha) starts at P - u1 t and ends at P + u2 t, t = R tan(|alpha| / 2).
    """
    p = np.asarray(corners_m, dtype=np.float64)
    n = p.shape[0]
    if n < 3:
        raise ValueError("a loop needs at least 3 corners")
    pieces: list[FloatArray] = []
    arcs: list[tuple[FloatArray, FloatArray]] = []
    for i in range(n):
        prev_p, here, next_p = p[i - 1], p[i], p[(i + 1) % n]
        u1 = (here - prev_p) / np.linalg.norm(here - prev_p)
        u2 = (next_p - here) / np.linalg.norm(next_p - here)
        alpha = float(np.arctan2(u1[0] * u2[1] - u1[1] * u2[0], float(u1 @ u2)))
        t = radius_m * np.tan(abs(alpha) / 2.0)
        if t > 0.5 * min(np.linalg.norm(here - prev_p), np.linalg.norm(next_p - here)):
            raise ValueError(f"corner {i}: radius {radius_m} m too large for its edges")
        start, end = here - u1 * t, here + u2 * t
        normal = np.array([-u1[1], u1[0]]) * np.sign(alpha)
        centre = start + normal * radius_m
        count = max(2, int(np.ceil(abs(alpha) * radius_m / _STEP_M)) + 1)
        a0 = np.arctan2(start[1] - centre[1], start[0] - centre[0])
        ang = a0 + np.linspace(0.0, alpha, count)
        arc = centre + radius_m * np.column_stack((np.cos(ang), np.sin(ang)))
        arcs.append((arc, end))
    for i in range(n):
        arc, _ = arcs[i]
        next_arc, _ = arcs[(i + 1) % n]
        a, b = arc[-1], next_arc[0]
        count = max(2, int(np.ceil(np.linalg.norm(b - a) / _STEP_M)) + 1)
        line = a + np.linspace(0.0, 1.0, count)[:, None] * (b - a)
        pieces.append(arc[:-1])
        pieces.append(line[:-1])
    xy = np.vstack([*pieces, pieces[0][:1]])
    seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
    keep = np.concatenate(([True], seg > 1e-9))
    xy = xy[keep]
    s = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1])))))
    return LoopPath(s_m=s, xy_m=xy)


def rounded_rectangle(
    width_m: float, height_m: float, radius_m: float, centre_m: tuple[float, float] = (0.0, 0.0)
) -> LoopPath:
    """A counter-clockwise rectangle loop with rounded corners, starting mid bottom edge."""
    cx, cy = centre_m
    w, h = width_m / 2.0, height_m / 2.0
    corners = [(cx + w, cy - h), (cx + w, cy + h), (cx - w, cy + h), (cx - w, cy - h)]
    path = rounded_polygon(corners, radius_m)
    # start at the middle of the bottom edge (heading east)
    start = np.array([cx, cy - h])
    i0 = int(np.argmin(np.hypot(path.xy_m[:, 0] - start[0], path.xy_m[:, 1] - start[1])))
    ring = np.roll(path.xy_m[:-1], -i0, axis=0)
    xy = np.vstack((ring, ring[:1]))
    s = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1])))))
    return LoopPath(s_m=s, xy_m=xy)
