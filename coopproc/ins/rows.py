"""The INS measurement models' rows, written once (issue 34 part 1): compiled, called by
the compiled loop (:mod:`coopproc.ins.kernels`) and by the numpy reference
(:mod:`coopproc.ins.updates`) alike.

Error state [dr (3), dv (3), phi (3), b_g (3), b_a (3), ...] with C = (I - [phi x]) C_hat
(:mod:`coopproc.ins.errorstate`). The range row is the range model's
(:mod:`coopproc.estimation.range_model`: unit vector and lever-arm column).
"""

from __future__ import annotations

import numba

from coopproc.model import FloatArray

__all__ = ["body_velocity_row", "position_row"]


@numba.njit(cache=True)
def position_row(cl: FloatArray, i: int, h: FloatArray) -> None:
    """Row ``i`` of the antenna position's H = [I, 0, [(C_b^n l) x]] (paper 003 eq. (29)),
    written to ``h`` (its other entries left as they are); ``cl`` = C_b^n l."""
    h[i] = 1.0
    h[6 + (i + 1) % 3] = -cl[(i + 2) % 3]
    h[6 + (i + 2) % 3] = cl[(i + 1) % 3]


@numba.njit(cache=True)
def body_velocity_row(
    c: FloatArray, v: FloatArray, w_b: FloatArray, lever: FloatArray, r: int, h: FloatArray
) -> float:
    """Component ``r`` of the body velocity of the point at ``lever``,
    v^b = (C_b^n)^T v^n + w^b x l, returned, and its row of
    H = [0, C^T, -C^T [v^n x], -[l x], 0] written to ``h`` (paper 003 eq. (24)-(27); the
    gyro-bias column is the lever-arm term's). ``c`` = C_b^n, ``w_b`` the compensated
    body rate (rad/s). Row 0 is the odometer's forward speed, rows 1, 2 the NHC."""
    a, b = (r + 1) % 3, (r + 2) % 3
    vb = w_b[a] * lever[b] - w_b[b] * lever[a]
    for i in range(3):
        vb += c[i, r] * v[i]
        h[3 + i] = c[i, r]
    h[6] = -(c[1, r] * v[2] - c[2, r] * v[1])
    h[7] = -(c[2, r] * v[0] - c[0, r] * v[2])
    h[8] = -(c[0, r] * v[1] - c[1, r] * v[0])
    h[9 + a] = lever[b]
    h[9 + b] = -lever[a]
    return vb
