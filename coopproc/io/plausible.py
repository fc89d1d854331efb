"""Is each navigation and reference file plausible for its platform? Checked before the work.

A file can hold numbers the readers accept and still not be a trajectory: positions in
millimetres, one glitched row 1,000 km away, a cell of ``1e300``. Every later stage then
computes nonsense (paper 000's Table 3 showed 54 km of own-navigation error for
positions x 1000) or fails deep inside a fit. The checks here run on every trajectory
once it is in the session's ENU frame, each finding one line naming the file, the line
and what is implausible, with the likely fix:

- **off the Earth** (a problem): a coordinate over :data:`MAX_OFFSET_M` (10,000 km) from
  the session origin, or one that conversion made non-finite (``1e300``);
- **units** (a problem): positions in millimetres, centimetres or kilometres. The ranges
  are the yardstick (they are checked for metres already, :mod:`coopproc.io.ranges_csv`,
  the same idea: a scale that makes the numbers plausible names the unit): the median
  range residual |range - |s p - q|| of a platform's ranges to partners whose positions
  are known (anchors, the other platforms' navigation) is computed for the scales s of
  UNIT_SCALES; a scale other than 1 that fits UNIT_GAIN times better than
  metres, to within UNIT_FIT of the median range, names the unit
  (:mod:`coopproc.io.plausible_units`). All the
  navigation files scaled together are tried first (a session written in mm throughout),
  then each file alone; only ENU-form files (lat/lon and ECEF have units of their own);
- **speed and jumps**: a step between consecutive epochs is implausible when it is
  longer than ``max_jump + max_speed * dt`` (the speed bound with a floor for position
  noise: it admits timestamp jitter, a 10 ms interval with a centimetre step, and a
  GNSS solution's noise). A **single-row glitch** (the steps into and out of a row both
  implausible, its neighbours' step plausible; or an implausible first or last step) is
  excluded, with a note, or a problem under ``--strict``; more than
  :data:`MAX_GLITCH_SHARE` of the rows glitched is a problem. Implausible steps on
  :data:`SUSTAINED_SHARE` of the record or more are a problem (a unit or a scale the
  ranges could not tell); fewer are jumps (a warning: a reset of the navigation's
  frame, a GNSS fix after a float);
- **acceleration** (a warning): the second difference of the positions on a grid
  :data:`ACCEL_BASE_S` apart (across no gap), over ``max_accel + 2 max_jump /
  ACCEL_BASE_S^2`` (the bound plus what position noise within ``max_jump`` makes of it);
- **velocities** (``vel_*`` columns, a problem): their median magnitude against the speed
  of the positions over the same epochs, a ratio near 3.6, 100 or 1000 reads as km/h,
  cm/s or mm/s.

The bounds are per role (:data:`ROLE_BOUNDS`), overridable per platform in session.toml
``[platforms.<ID>] max_speed``, ``max_accel``, ``max_jump`` (docs/formats.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from coopproc.errors import CoopprocError
from coopproc.io._common import RawTrajectory
from coopproc.io.plausible_units import position_units
from coopproc.model import FloatArray, Platform, RangeTable, Trajectory, gap_limit_s

__all__ = [
    "ACCEL_BASE_S",
    "MAX_GLITCH_SHARE",
    "MAX_OFFSET_M",
    "ROLE_BOUNDS",
    "SUSTAINED_SHARE",
    "WARNING",
    "Bounds",
    "Plausibility",
    "apply_plausible",
    "bounds_of",
    "check_plausible",
]


@dataclass(frozen=True)
class Bounds:
    """What a platform's trajectory may do: speed m/s, acceleration m/s^2, noise step m."""

    max_speed_mps: float
    max_accel_mps2: float
    max_jump_m: float


#: Default bounds per role, chosen on the shared real sessions (data/real: plaza2's robot
#: is the fastest at 4.8 m/s and 2.3 m/s^2 at most on a 1-s base, miluv1's quadrotor
#: 1.7 m/s, the others walk or crawl; the largest step between epochs is 1.24 m) and on
#: what the roles may carry: a car on a motorway (70 m/s = 252 km/h; 20 m/s^2 = 2 g,
#: twice a car's emergency braking) and a code-GNSS solution's epoch-to-epoch noise
#: (a few metres: max_jump 5 m). An anchor does not move: 1 m/s admits a surveyed
#: anchor's GNSS noise. A tag moves like the others.
ROLE_BOUNDS: dict[str, Bounds] = {
    "follower": Bounds(70.0, 20.0, 5.0),
    "leader": Bounds(70.0, 20.0, 5.0),
    "tag": Bounds(70.0, 20.0, 5.0),
    "anchor": Bounds(1.0, 5.0, 5.0),
}
#: A coordinate this far from the session origin, m, is not on the Earth (10,000 km).
MAX_OFFSET_M = 1e7
#: Implausible steps on this share of the record: not glitches, a unit or a scale.
SUSTAINED_SHARE = 0.2
#: Single-row glitches on more than this share of the rows are not single glitches.
MAX_GLITCH_SHARE = 0.01
#: The grid of the acceleration check, s (a 1-s base gives 2.3 m/s^2 at most on the
#: shared real sessions; 2 s halves the noise term again).
ACCEL_BASE_S = 2.0
#: Velocity units told by the ratio of the vel_* magnitudes to the positions' speed.
_VEL_UNITS: tuple[tuple[float, str, str], ...] = (
    (3.6, "km/h", "km/h"),
    (100.0, "cm/s", "cm/s"),
    (1000.0, "mm/s", "mm/s"),
)
#: A ratio within this factor of a unit's names it; speeds below this are not moving.
_VEL_TOLERANCE = 1.25
_MOVING_MPS = 0.1
#: The prefix of a note that is a warning (validate counts it; run prints it so).
WARNING = "warning: "


def bounds_of(platform: Platform | None) -> Bounds:
    """The platform's bounds: its session.toml keys, else its role's defaults."""
    base = ROLE_BOUNDS[platform.role if platform is not None else "follower"]
    if platform is None:
        return base
    speed, accel, jump = platform.max_motion
    return Bounds(
        speed or base.max_speed_mps, accel or base.max_accel_mps2, jump or base.max_jump_m
    )


@dataclass
class Plausibility:
    """What the checks found: problems, warnings, notes, and the rows to keep per file."""

    problems: list[CoopprocError] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: source -> rows kept (only files with glitched rows excluded).
    keep: dict[str, NDArray[np.intp]] = field(default_factory=dict)


def _bad_steps(t: FloatArray, p: FloatArray, b: Bounds) -> tuple[NDArray[np.bool_], FloatArray]:
    """Implausible steps between consecutive epochs, and every step's length, m."""
    step = np.linalg.norm(np.diff(p, axis=0), axis=1)
    return step > b.max_jump_m + b.max_speed_mps * np.diff(t), step


def _glitches(t: FloatArray, p: FloatArray, b: Bounds, bad: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Rows that are single-row glitches (see the module text)."""
    n = t.size
    if n < 3 or not bad.any():
        return np.empty(0, dtype=np.intp)
    inner = np.zeros(n, dtype=bool)
    inner[1:-1] = bad[:-1] & bad[1:]
    k = np.flatnonzero(inner)
    over = np.linalg.norm(p[k + 1] - p[k - 1], axis=1)
    ok = over <= b.max_jump_m + b.max_speed_mps * (t[k + 1] - t[k - 1])
    rows = list(k[ok])
    if bad[0] and not bad[1]:
        rows.insert(0, 0)
    if bad[-1] and not bad[-2]:
        rows.append(n - 1)
    return np.asarray(rows, dtype=np.intp)


def _role(platforms: Mapping[str, Platform], pid: str) -> str:
    p = platforms.get(pid)
    return p.role if p is not None else "follower"


def _kinematics(
    raw: RawTrajectory,
    traj: Trajectory,
    b: Bounds,
    role: str,
    strict: bool,
    out: Plausibility,
) -> None:
    """Speed, jumps, glitches and acceleration of one trajectory (see the module text)."""
    t, p = traj.time_s, traj.enu_m
    if t.size < 2:
        return
    src = traj.source
    bound = f"a {role}'s bound is {b.max_speed_mps:g} m/s + {b.max_jump_m:g} m per epoch"
    fix = f"set session.toml [platforms.{traj.platform}] max_speed"
    bad, step = _bad_steps(t, p, b)
    if np.count_nonzero(bad) >= SUSTAINED_SHARE * bad.size and bad.size >= 5:
        k = int(np.flatnonzero(bad)[0])
        speed = float(np.median(step / np.diff(t)))
        out.problems.append(
            raw.error(
                f"implausible speeds: {np.count_nonzero(bad)} of {bad.size} steps over the "
                f"bound, median {speed:,.4g} m/s ({bound}); expected metres and seconds: "
                "positions in mm or cm, or times in ms? (or " + fix + ")",
                k + 1,
            )
        )
        return
    glitch = _glitches(t, p, b, bad)
    if glitch.size > max(1, MAX_GLITCH_SHARE * t.size):
        out.problems.append(
            raw.error(
                f"{glitch.size} single-row glitches (rows far off their neighbours; {bound}); "
                f"expected at most {MAX_GLITCH_SHARE:.0%} of the rows: a corrupt file?",
                int(glitch[0]),
                glitch.size,
            )
        )
        return
    if glitch.size:
        g = int(glitch[0])
        nb = g - 1 if g > 0 else g + 1
        off = float(np.linalg.norm(p[g] - p[nb]))
        what = (
            f"{glitch.size} single-row glitch{'es' * (glitch.size > 1)}: a row {off:,.1f} m off "
            f"its neighbour ({bound})"
        )
        if strict:
            out.problems.append(
                raw.error(f"{what}; expected a plausible trajectory (--strict)", g, glitch.size)
            )
            return
        err = raw.error(f"{what}; excluded", g, glitch.size)
        out.notes.append(str(err))
        keep = np.setdiff1d(np.arange(t.size), glitch)
        out.keep[src] = keep
        t, p = t[keep], p[keep]
        if t.size < 2:
            return
        bad, step = _bad_steps(t, p, b)
        rows = keep
    else:
        rows = np.arange(t.size)
    if bad.any():
        idx = np.flatnonzero(bad)
        k = int(idx[np.argmax(step[idx])])
        dt = float(t[k + 1] - t[k])
        err = raw.error(
            f"position jumps {step[k]:,.4g} m in {dt:.3g} s ({bound}; {idx.size} such "
            f"step{'s' * (idx.size > 1)}, the largest here): a reset of the navigation's "
            f"frame, or a glitch of several rows? (or {fix} / max_jump)",
            int(rows[k + 1]),
        )
        out.warnings.append(str(err))
        return  # the jump's own acceleration would only repeat it
    _acceleration(raw, t, p, rows, b, role, out)


def _acceleration(
    raw: RawTrajectory,
    t: FloatArray,
    p: FloatArray,
    rows: NDArray[np.intp],
    b: Bounds,
    role: str,
    out: Plausibility,
) -> None:
    """The acceleration check on a grid ACCEL_BASE_S apart (see the module text)."""
    span = float(t[-1] - t[0])
    if not 3 * ACCEL_BASE_S <= span <= ACCEL_BASE_S * (4 * t.size + 1000) or t.size < 4:
        return  # too short, or a span mostly gaps (absurd times: the time checks say so)
    grid = t[0] + ACCEL_BASE_S * np.arange(int(span // ACCEL_BASE_S) + 1)
    pos = np.column_stack([np.interp(grid, t, p[:, k]) for k in range(3)])
    # a grid point inside a gap is invented: the second differences using it are not used
    right = np.clip(np.searchsorted(t, grid), 1, t.size - 1)
    limit = max(gap_limit_s(t), ACCEL_BASE_S)
    valid = (t[right] - t[right - 1]) <= limit
    acc = np.linalg.norm(pos[2:] - 2 * pos[1:-1] + pos[:-2], axis=1) / ACCEL_BASE_S**2
    use = valid[2:] & valid[1:-1] & valid[:-2]
    limit_a = b.max_accel_mps2 + 2 * b.max_jump_m / ACCEL_BASE_S**2
    over = use & (acc > limit_a)
    if not over.any():
        return
    idx = np.flatnonzero(over)
    k = int(idx[np.argmax(acc[idx])])
    row = int(rows[min(int(np.searchsorted(t, grid[k + 1])), t.size - 1)])
    err = raw.error(
        f"accelerates at {acc[k]:,.4g} m/s^2 over {ACCEL_BASE_S:g} s ({idx.size} such "
        f"stretch{'es' * (idx.size > 1)}; a {role}'s bound is {b.max_accel_mps2:g} m/s^2 + "
        f"{2 * b.max_jump_m / ACCEL_BASE_S**2:g} for position noise): a glitch of several "
        f"rows? (or set session.toml [platforms.{raw.platform}] max_accel)",
        row,
    )
    out.warnings.append(str(err))


def _velocity(raw: RawTrajectory, traj: Trajectory, out: Plausibility) -> bool:
    """The vel_* columns' unit against the positions' speed; False when they fail."""
    vel = traj.vel_enu_mps
    if vel is None or traj.time_s.size < 3:
        return True
    t, p = traj.time_s, traj.enu_m
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(t)
    given = 0.5 * (np.linalg.norm(vel[1:], axis=1) + np.linalg.norm(vel[:-1], axis=1))
    moving = speed > _MOVING_MPS
    if np.count_nonzero(moving) < 10:
        return True
    ratio = float(np.median(given[moving]) / np.median(speed[moving]))
    for factor, unit, key in _VEL_UNITS:
        if factor / _VEL_TOLERANCE <= ratio <= factor * _VEL_TOLERANCE:
            out.problems.append(
                raw.error(
                    f"velocities look like {unit} (their median magnitude is {ratio:.3g} x "
                    "the speed of the positions); expected m/s: divide them by "
                    f"{factor:g}, or declare session.toml [columns.units] velocity = "
                    f'"{key}"',
                    0,
                )
            )
            return False
    return True


def check_plausible(
    nav_raw: Mapping[str, RawTrajectory],
    ref_raw: Mapping[str, RawTrajectory],
    nav: Mapping[str, Trajectory],
    reference: Mapping[str, Trajectory],
    platforms: Mapping[str, Platform],
    ranges: RangeTable | None,
    *,
    strict: bool = False,
) -> Plausibility:
    """Every check of the module text on every navigation and reference trajectory."""
    out = Plausibility()
    sane: dict[str, Trajectory] = {}
    off: set[str] = set()  # sources off the Earth: no other check of them
    for group, raws in ((nav, nav_raw), (reference, ref_raw)):
        for pid in sorted(group):
            traj, raw = group[pid], raws[pid]
            with np.errstate(invalid="ignore"):
                far = ~np.isfinite(traj.enu_m).all(axis=1) | (
                    np.abs(traj.enu_m) > MAX_OFFSET_M
                ).any(axis=1)
            if far.any():
                idx = np.flatnonzero(far)
                value = float(np.max(np.abs(traj.enu_m[idx[0]])))
                out.problems.append(
                    raw.error(
                        f"position {value:.4g} m from the session origin is not on the "
                        f"Earth (over {MAX_OFFSET_M:.0e} m); expected metres (a corrupt or "
                        "overflowing cell?)",
                        int(idx[0]),
                        idx.size,
                    )
                )
                off.add(traj.source)
            elif group is nav:
                sane[pid] = traj
    wrong_unit = position_units(nav_raw, sane, platforms, ranges, out.problems)
    for group, raws in ((nav, nav_raw), (reference, ref_raw)):
        for pid in sorted(group):
            traj = group[pid]
            if traj.source in off or (group is nav and pid in wrong_unit):
                continue
            if not _velocity(raws[pid], traj, out):
                continue
            p = platforms.get(pid)
            _kinematics(raws[pid], traj, bounds_of(p), _role(platforms, pid), strict, out)
    return out


def apply_plausible(
    found: Plausibility,
    raws: tuple[Mapping[str, RawTrajectory], Mapping[str, RawTrajectory]],
    groups: tuple[dict[str, Trajectory], dict[str, Trajectory]],
    origin: tuple[float, float, float],
) -> list[str]:
    """Rebuild the trajectories whose glitched rows were excluded (in ``groups``: nav,
    reference) and return the notes to record: the exclusions, then the warnings as
    ``warning: ...`` notes (validate counts them as warnings, run prints them so)."""
    from coopproc.io.assemble import to_trajectory

    for raw_group, group in zip(raws, groups, strict=True):
        for pid, raw in raw_group.items():
            keep = found.keep.get(raw.source)
            if keep is not None and pid in group:
                group[pid] = to_trajectory(raw.take(keep), origin)
    return [*found.notes, *(f"{WARNING}{w}" for w in found.warnings)]
