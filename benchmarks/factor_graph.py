"""Compare coopproc's fused positions with a GTSAM batch factor graph on the same session.

A strong baseline, not a timing: for each session, one 2-D pose graph over every moving
platform that has navigation, solved in batch with GTSAM's Levenberg-Marquardt, scored
against the session's reference beside coopproc's own fused ``observed`` solution and the
platform's own navigation. The graph (docs/benchmarks.md, "Factor-graph baseline"):

- **states**: one ``Pose2`` (east, north, yaw) per platform at the times of the ranges
  it takes part in, merged within ``--merge`` s (0.05), inside its navigation span; the
  two ends of an inter-platform range fall on states of the same epoch;
- **odometry**: a ``BetweenFactorPose2`` between consecutive states: the relative pose of
  the navigation at the two times (position interpolated; yaw from the nav's heading
  column, else the direction of the nav track over +-0.5 s, held while standing still),
  with sigmas that grow with the distance the nav travelled: ``xy = --odo-xy-floor *
  sqrt(dt) + --odo-xy-frac * d`` (per axis), ``yaw = --odo-yaw-floor * sqrt(dt) +
  --odo-yaw-per-m * d``: dead reckoning's error comes with distance (scale, heading
  drift), a small random walk keeps a standing platform's pose free to move a little;
- **priors**: the first state of each platform at its navigation there (its first
  sample when ranging starts with the nav; the nav's sigma, else 0.1 m; yaw 0.3 rad);
  a leader's every state gets a position-only
  prior (``PoseTranslationPrior2D``) from its navigation, ``--leader-sigma`` (0.05 m);
- **ranges**: an anchor is a ``Point2`` variable held by a 1 mm prior, a range to it a
  ``RangeFactor2D``; a range between two platforms a ``RangeFactorPose2`` between their
  states. The noise is Huber (k = 1.345) on the row's ``sigma``, else session.toml
  ``[uwb] sigma``, else 0.15 m. The graph is 2-D: each range is reduced to horizontal,
  ``sqrt(r^2 - dz^2)``, with dz from the navigation's (or anchor's) up.

The odometry sigmas are solved twice: as given ("FG fixed") and scaled by the factors
(xy, yaw) that maximize the evidence of the data ("FG ML", type-II maximum likelihood:
the Laplace approximation, -error - log det R - the odometry log sigmas, over factors
1/64 ... 64; one fixed model cannot suit a dead reckoning accurate over kilometres and
one that drifts metres in 30 s). ``--no-tune`` skips that search. No reference is used
to choose anything.

Each graph is solved by Levenberg-Marquardt from the dead-reckoning poses. Where that does not
converge to a consistent solution (more than ``--bad-fraction`` of the range residuals
beyond 3 sigma, or LM ending with a higher error than it started), it is solved again
from a rough range-based start: the graph solved incrementally with iSAM2, state by state
(each new state predicted by its odometry from the last estimate), and LM from that.

coopproc runs as ``python -P -m coopproc run SESSION -o DIR/NAME --no-figures --force``
(``--coopproc-out DIR``: keep the outputs there; a positions.csv already there is reused
unless ``--rerun``), and its ``positions.csv`` gives the mean horizontal error of the
``nav`` and ``observed`` rows (own navigation; the cooperative fusion of the observed
ranges, RTS-smoothed) over the span of the graph's states. Both are scored against
``session.reference`` (coopproc's ``error_h``: the reference interpolated, nothing across
its gaps).

    python benchmarks/factor_graph.py              # plaza2, tuc, paper-experiment seed 0
    python benchmarks/factor_graph.py ../shared/data/real/plaza2 --coopproc-out /tmp/base
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pandas as pd
from _common import load

from coopproc.io import read_session
from coopproc.model import Session, Trajectory

REPO = Path(__file__).resolve().parents[1]
DEFAULT_SESSIONS = ("../shared/data/real/plaza2", "../shared/data/real/tuc")
SIMULATED = "paper-experiment"
#: a range's sigma when neither its row nor session.toml gives one
FALLBACK_SIGMA_M = 0.15
#: log-evidence gain that a new odometry sigma factor must bring to be taken
EVIDENCE_MARGIN = 1.0
#: Huber threshold, in sigmas (95 % efficiency on Gaussian noise)
HUBER_K = 1.345


def import_gtsam() -> ModuleType | None:
    """gtsam, or None when it is not installed."""
    try:
        import gtsam
    except ImportError:
        return None
    return gtsam


@dataclass
class Options:
    merge_s: float = 0.05
    odo_xy_floor: float = 0.01  # m / sqrt(s)
    odo_xy_frac: float = 0.05  # m per m travelled
    odo_yaw_floor: float = 0.005  # rad / sqrt(s)
    odo_yaw_per_m: float = 0.01  # rad per m travelled
    leader_sigma: float = 0.05  # m
    bad_fraction: float = 0.3
    #: factors on the odometry sigmas above (chosen by :func:`tune`)
    xy_scale: float = 1.0
    yaw_scale: float = 1.0


@dataclass
class Graph:
    """The graph of one session and what scoring it needs."""

    graph: Any
    initial: Any
    #: platform -> state times; the key of state i of platform p is keys[p][i]
    times: dict[str, np.ndarray] = field(default_factory=dict)
    keys: dict[str, np.ndarray] = field(default_factory=dict)
    #: (key, key or anchor key, horizontal range, sigma) of every range factor, for checks
    ranges: list[tuple[int, int, float, float]] = field(default_factory=list)
    #: odometry factors in order of their second state, for the incremental start
    order: list[tuple[float, str, int]] = field(default_factory=list)
    #: keys of the anchors' Point2 variables
    anchors: set[int] = field(default_factory=set)
    #: sum of the log sigmas of the odometry factors (the evidence's normalizer)
    odo_log_sigma: float = 0.0


def session_sigma(session: Session) -> float:
    """session.toml ``[uwb] sigma``, else the fallback (as coopproc's fusion defaults it)."""
    sigma = session.config.uwb_sigma_m
    return float(sigma) if sigma is not None and sigma > 0 else FALLBACK_SIGMA_M


def merged_times(times: np.ndarray, merge_s: float) -> np.ndarray:
    """Sorted unique times with runs closer than ``merge_s`` merged into their first."""
    t = np.unique(times)
    if t.size == 0:
        return t
    starts = np.concatenate([[True], np.diff(t) > merge_s])
    # a run is cut where the gap to its first time would pass merge_s, not only the step
    keep = []
    first = -math.inf
    for value, start in zip(t, starts, strict=True):
        if start or value - first > merge_s:
            keep.append(value)
            first = value
    return np.asarray(keep, dtype=np.float64)


def track_yaw(nav: Trajectory, times: np.ndarray, half_window_s: float = 0.5) -> np.ndarray:
    """ENU yaw (rad, counter-clockwise from east) of the nav at ``times``: its heading
    column if it has one, else the direction of its track over +-half_window_s, held
    (forward, then backward) where it moved less than 2 cm."""
    if nav.heading_deg is not None and np.isfinite(nav.heading_deg).all():
        compass = np.unwrap(np.radians(nav.heading_deg))
        return np.pi / 2.0 - np.interp(times, nav.time_s, compass)
    lo, hi = nav.span_s
    ahead = nav.interpolate(np.clip(times + half_window_s, lo, hi))
    behind = nav.interpolate(np.clip(times - half_window_s, lo, hi))
    d = ahead[:, :2] - behind[:, :2]
    yaw = pd.Series(
        np.where(np.hypot(d[:, 0], d[:, 1]) > 0.02, np.arctan2(d[:, 1], d[:, 0]), np.nan)
    )
    return yaw.ffill().bfill().fillna(0.0).to_numpy(np.float64)


def build_graph(gtsam: ModuleType, session: Session, opts: Options) -> Graph:
    """The factor graph of a session (module docstring) and its dead-reckoning start."""
    symbol = gtsam.symbol
    graph = gtsam.NonlinearFactorGraph()
    initial = gtsam.Values()
    out = Graph(graph, initial)
    frame = session.ranges.frame
    frame = frame[np.isfinite(frame["range"].to_numpy(np.float64))]
    frame = frame[frame["range"] > 0]
    fallback = session_sigma(session)
    if "sigma" in frame.columns:
        sig = pd.to_numeric(frame["sigma"], errors="coerce").to_numpy(np.float64)
    else:
        sig = np.full(len(frame), np.nan)
    sig = np.where(np.isfinite(sig) & (sig > 0), sig, fallback)
    t_all = frame["time"].to_numpy(np.float64)
    src = frame["from"].astype(str).to_numpy()
    dst = frame["to"].astype(str).to_numpy()
    r_all = frame["range"].to_numpy(np.float64)

    moving = [p for p in session.moving_platforms() if p in session.nav and len(session.nav[p]) > 1]
    anchors = {
        p: np.asarray(pl.position_enu_m, dtype=np.float64)
        for p, pl in session.platforms.items()
        if pl.role == "anchor" and pl.position_enu_m is not None
    }
    nav_pose: dict[str, np.ndarray] = {}
    nav_up: dict[str, np.ndarray] = {}
    for index, pid in enumerate(moving):
        nav = session.nav[pid]
        lo, hi = nav.span_s
        mine = ((src == pid) | (dst == pid)) & (t_all >= lo) & (t_all <= hi)
        times = merged_times(t_all[mine], opts.merge_s)
        if times.size < 2:
            continue
        pos = nav.interpolate(times)
        yaw = track_yaw(nav, times)
        out.times[pid] = times
        out.keys[pid] = np.array([symbol(chr(ord("a") + index % 26), i) for i in range(times.size)])
        nav_pose[pid] = np.column_stack([pos[:, :2], yaw])
        nav_up[pid] = pos[:, 2]
        keys = out.keys[pid]
        poses = [gtsam.Pose2(x, y, th) for x, y, th in nav_pose[pid]]
        for key, pose in zip(keys, poses, strict=True):
            initial.insert(int(key), pose)
        # the first pose from the nav at the first state (its first sample, or
        # interpolated when the first range comes later)
        first = pos[0]
        s_xy = 0.1
        if nav.sigma_enu_m is not None:
            at = int(np.clip(np.searchsorted(nav.time_s, times[0]), 0, len(nav) - 1))
            if np.isfinite(nav.sigma_enu_m[at, :2]).all():
                s_xy = max(float(np.max(nav.sigma_enu_m[at, :2])), 0.01)
        prior = gtsam.Pose2(float(first[0]), float(first[1]), float(yaw[0]))
        graph.add(
            gtsam.PriorFactorPose2(
                int(keys[0]), prior, gtsam.noiseModel.Diagonal.Sigmas(np.array([s_xy, s_xy, 0.3]))
            )
        )
        # odometry from the platform's own navigation
        dt = np.diff(times)
        dist = np.hypot(*np.diff(pos[:, :2], axis=0).T)
        for i in range(times.size - 1):
            s_xy = opts.odo_xy_floor * math.sqrt(dt[i]) + opts.odo_xy_frac * dist[i]
            s_th = opts.odo_yaw_floor * math.sqrt(dt[i]) + opts.odo_yaw_per_m * dist[i]
            s_xy, s_th = s_xy * opts.xy_scale, s_th * opts.yaw_scale
            out.odo_log_sigma += 2.0 * math.log(s_xy) + math.log(s_th)
            noise = gtsam.noiseModel.Diagonal.Sigmas(np.array([s_xy, s_xy, s_th]))
            graph.add(
                gtsam.BetweenFactorPose2(
                    int(keys[i]), int(keys[i + 1]), poses[i].between(poses[i + 1]), noise
                )
            )
            out.order.append((float(times[i + 1]), pid, i + 1))
        if session.platforms[pid].role == "leader":
            gps = gtsam.noiseModel.Isotropic.Sigma(2, opts.leader_sigma)
            for key, (x, y, _) in zip(keys, nav_pose[pid], strict=True):
                graph.add(gtsam.PoseTranslationPrior2D(int(key), np.array([x, y]), gps))

    anchor_key = {}
    for index, (aid, position) in enumerate(sorted(anchors.items())):
        key = symbol("L", index)
        anchor_key[aid] = key
        out.anchors.add(key)
        point = gtsam.Point2(float(position[0]), float(position[1]))
        initial.insert(key, point)
        graph.add(gtsam.PriorFactorPoint2(key, point, gtsam.noiseModel.Isotropic.Sigma(2, 1e-3)))

    def state(pid: str, t: float) -> tuple[int, float] | None:
        """Key and nav up of the state of ``pid`` nearest ``t`` (None: not in the graph)."""
        times = out.times.get(pid)
        if times is None or t < times[0] - opts.merge_s or t > times[-1] + opts.merge_s:
            return None
        i = int(np.clip(np.searchsorted(times, t), 1, times.size - 1))
        i = i - 1 if t - times[i - 1] <= times[i] - t else i
        return int(out.keys[pid][i]), float(nav_up[pid][i])

    for t, a, b, r, s in zip(t_all, src, dst, r_all, sig, strict=True):
        if a in anchors and b in anchors:
            continue
        if b in anchors:
            a, b = b, a
        robust = gtsam.noiseModel.Robust.Create(
            gtsam.noiseModel.mEstimator.Huber.Create(HUBER_K),
            gtsam.noiseModel.Isotropic.Sigma(1, float(s)),
        )
        end_b = state(b, t)
        if end_b is None:
            continue
        if a in anchors:
            dz = end_b[1] - float(anchors[a][2])
            rh = math.sqrt(max(r * r - dz * dz, 1e-6))
            graph.add(gtsam.RangeFactor2D(end_b[0], anchor_key[a], rh, robust))
            out.ranges.append((end_b[0], anchor_key[a], rh, float(s)))
            continue
        end_a = state(a, t)
        if end_a is None or end_a[0] == end_b[0]:
            continue
        dz = end_b[1] - end_a[1]
        rh = math.sqrt(max(r * r - dz * dz, 1e-6))
        graph.add(gtsam.RangeFactorPose2(end_a[0], end_b[0], rh, robust))
        out.ranges.append((end_a[0], end_b[0], rh, float(s)))
    out.order.sort()
    return out


def bad_share(g: Graph, values: Any) -> float:
    """Share of range factors whose residual is beyond 3 sigma at ``values``."""
    if not g.ranges:
        return 0.0
    bad = 0
    for k1, k2, r, s in g.ranges:
        p1 = values.atPose2(k1).translation()
        p2 = values.atPoint2(k2) if k2 in g.anchors else values.atPose2(k2).translation()
        bad += abs(float(np.hypot(*(np.asarray(p1) - np.asarray(p2)))) - r) > 3.0 * s
    return bad / len(g.ranges)


def lm(gtsam: ModuleType, g: Graph, start: Any) -> tuple[Any, float, float, int]:
    """LM from ``start``: the values, the error before and after, the iterations."""
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(200)
    params.setRelativeErrorTol(1e-7)
    params.setAbsoluteErrorTol(1e-9)
    optimizer = gtsam.LevenbergMarquardtOptimizer(g.graph, start, params)
    before = g.graph.error(start)
    result = optimizer.optimize()
    return result, before, g.graph.error(result), optimizer.iterations()


def incremental_start(gtsam: ModuleType, g: Graph) -> Any:
    """A range-corrected start: iSAM2 adding the states in time order, each new state
    predicted by its odometry from the current estimate of the one before."""
    isam = gtsam.ISAM2()
    sequence = sorted([(float(g.times[p][0]), p, 0) for p in g.times] + g.order)
    # each factor is added with the last of its variables to be added
    when = {int(g.keys[pid][i]): rank for rank, (_, pid, i) in enumerate(sequence)}
    when.update({k: -1 for k in g.anchors})
    factors_of: dict[int, list[Any]] = {}
    for j in range(g.graph.size()):
        factor = g.graph.at(j)
        if factor is not None:
            factors_of.setdefault(max(when[int(k)] for k in list(factor.keys())), []).append(factor)
    estimate = gtsam.Values()
    pending = gtsam.NonlinearFactorGraph()
    fresh = gtsam.Values()
    for k in g.anchors:
        fresh.insert(k, g.initial.atPoint2(k))
    for f in factors_of.get(-1, []):
        pending.add(f)
    for rank, (_, pid, i) in enumerate(sequence):
        key = int(g.keys[pid][i])
        guess = g.initial.atPose2(key)
        if i > 0:
            prev = int(g.keys[pid][i - 1])
            odo = g.initial.atPose2(prev).between(guess)
            guess = estimate.atPose2(prev).compose(odo)
        fresh.insert(key, guess)
        for f in factors_of.get(rank, []):
            pending.add(f)
        isam.update(pending, fresh)
        estimate = isam.calculateEstimate()
        pending = gtsam.NonlinearFactorGraph()
        fresh = gtsam.Values()
    return estimate


def solve(gtsam: ModuleType, g: Graph, opts: Options) -> tuple[Any, str]:
    """The optimized values and how they were reached."""
    result, before, after, iters = lm(gtsam, g, g.initial)
    share = bad_share(g, result)
    how = f"LM from DR: {iters} it, error {before:.3g} -> {after:.3g}, {share:.0%} ranges > 3 sigma"
    if after <= before and share <= opts.bad_fraction:
        return result, how
    start = incremental_start(gtsam, g)
    result2, before2, after2, iters2 = lm(gtsam, g, start)
    share2 = bad_share(g, result2)
    how += (
        f"; again from iSAM2 start: {iters2} it, error {before2:.3g} -> {after2:.3g}, "
        f"{share2:.0%} > 3 sigma"
    )
    return (result2, how) if after2 < after else (result, how)


def log_evidence(g: Graph, values: Any) -> float:
    """Laplace approximation of log p(ranges, odometry, priors | odometry sigmas), up to
    what does not depend on them: -error - log det R (R: the square-root information at
    ``values``, so 0.5 log det of the Hessian) - the odometry factors' log sigmas."""
    tree = g.graph.linearize(values).eliminateMultifrontal()
    return -g.graph.error(values) - tree.logDeterminant() - g.odo_log_sigma


def tune(
    gtsam: ModuleType, session: Session, opts: Options, rounds: int = 2
) -> tuple[Options, str]:
    """The odometry sigma factors (xy, yaw) of largest :func:`log_evidence`: a search
    over factors 1, 1/4, 4, ... 1/64, 64 of each in turn, ``rounds`` times, then
    half and twice the best of each; every graph solved by LM warm-started from the
    best solution so far. A factor replaces the best only if it raises the evidence by
    :data:`EVIDENCE_MARGIN` (on a plateau the first factor tried stays)."""
    g = build_graph(gtsam, session, opts)
    values, _, _, _ = lm(gtsam, g, g.initial)
    best, best_score, tried = opts, log_evidence(g, values), 1

    def trial(**scales: float) -> None:
        nonlocal best, best_score, values, tried
        cand = dataclasses.replace(best, **scales)
        gc = build_graph(gtsam, session, cand)
        tried += 1
        try:
            vc, _, _, _ = lm(gtsam, gc, values)
            score = log_evidence(gc, vc)
        except RuntimeError:  # indeterminate (an extreme factor): not a candidate
            return
        if score > best_score + EVIDENCE_MARGIN:
            best, best_score, values = cand, score, vc

    for _ in range(rounds):
        for axis in ("xy_scale", "yaw_scale"):
            for f in sorted(4.0 ** np.arange(-3, 4), key=lambda f: abs(math.log(f))):
                if f != getattr(best, axis):
                    trial(**{axis: float(f)})
    for axis in ("xy_scale", "yaw_scale"):
        at = getattr(best, axis)
        for f in (at / 2.0, at * 2.0):
            trial(**{axis: float(f)})
    return best, (
        f"odometry sigmas x {best.xy_scale:g} (xy), x {best.yaw_scale:g} (yaw) by evidence "
        f"({tried} graphs)"
    )


def fit(
    gtsam: ModuleType, session: Session, opts: Options, tuned: bool
) -> tuple[dict[str, np.ndarray], Graph]:
    """Solve the session's graph (odometry sigmas tuned by evidence or not); the (n, 2)
    positions of every platform's states, and the graph. Prints one line."""
    start = time.perf_counter()
    note = "default odometry sigmas"
    if tuned:
        opts, note = tune(gtsam, session, opts)
    g = build_graph(gtsam, session, opts)
    values, how = solve(gtsam, g, opts)
    n_states = sum(t.size for t in g.times.values())
    print(
        f"{session.name}: {n_states} states, {g.graph.size()} factors ({len(g.ranges)} "
        f"ranges), {note}; {how}; {time.perf_counter() - start:.2f} s"
    )
    xy = {
        pid: np.array([np.asarray(values.atPose2(int(k)).translation()) for k in keys])
        for pid, keys in g.keys.items()
    }
    return xy, g


def horizontal_errors(session: Session, pid: str, times: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Horizontal distance to the reference at ``times`` (NaN where it has none)."""
    ref = session.reference.get(pid)
    if ref is None or len(ref) == 0:
        return np.full(times.size, np.nan)
    at = ref.interpolate_within(times)
    return np.asarray(np.hypot(xy[:, 0] - at[:, 0], xy[:, 1] - at[:, 1]), dtype=np.float64)


def coopproc_positions(session_path: Path, out: Path, rerun: bool) -> tuple[pd.DataFrame, float]:
    """coopproc's positions.csv of the session (run into ``out`` unless there already)."""
    csv = out / "positions.csv"
    if csv.is_file() and not rerun:
        return pd.read_csv(csv), float("nan")
    out.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    cmd = [sys.executable, "-P", "-m", "coopproc", "run", str(session_path), "-o", str(out)]
    proc = subprocess.run(
        [*cmd, "--no-figures", "--force", "-q"], capture_output=True, text=True, check=False
    )
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"coopproc run {session_path} failed:\n{proc.stderr}")
    return pd.read_csv(csv), seconds


def mean_rmse(err: np.ndarray) -> tuple[float, float, int]:
    e = err[np.isfinite(err)]
    if e.size == 0:
        return float("nan"), float("nan"), 0
    return float(e.mean()), float(np.sqrt(np.mean(e * e))), int(e.size)


def simulated_session(root: Path) -> Path:
    """``coopproc simulate ROOT/SIMULATED --scenario SIMULATED --seed 0``."""
    path = root / SIMULATED
    cmd = [sys.executable, "-P", "-m", "coopproc", "simulate", str(path)]
    proc = subprocess.run(
        [*cmd, "--scenario", SIMULATED, "--seed", "0", "--force"],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        raise SystemExit(f"coopproc simulate failed:\n{proc.stderr}")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "sessions",
        nargs="*",
        type=Path,
        help="session directories (default: plaza2, tuc and paper-experiment seed 0)",
    )
    parser.add_argument(
        "--coopproc-out",
        type=Path,
        help="keep coopproc's outputs in DIR/NAME (reused if there, unless --rerun)",
    )
    parser.add_argument(
        "--rerun", action="store_true", help="run coopproc even if DIR/NAME has outputs"
    )
    defaults = Options()
    parser.add_argument("--merge", type=float, default=defaults.merge_s, help="s (0.05)")
    parser.add_argument("--odo-xy-floor", type=float, default=defaults.odo_xy_floor)
    parser.add_argument("--odo-xy-frac", type=float, default=defaults.odo_xy_frac)
    parser.add_argument("--odo-yaw-floor", type=float, default=defaults.odo_yaw_floor)
    parser.add_argument("--odo-yaw-per-m", type=float, default=defaults.odo_yaw_per_m)
    parser.add_argument("--leader-sigma", type=float, default=defaults.leader_sigma)
    parser.add_argument("--bad-fraction", type=float, default=defaults.bad_fraction)
    parser.add_argument(
        "--no-tune", action="store_true", help="FG ML = FG fixed: no evidence search"
    )
    args = parser.parse_args()

    gtsam = import_gtsam()
    if gtsam is None:
        print("factor_graph: gtsam is not installed (pip install -e '.[bench]'); skipped")
        return
    opts = Options(
        args.merge, args.odo_xy_floor, args.odo_xy_frac, args.odo_yaw_floor,
        args.odo_yaw_per_m, args.leader_sigma, args.bad_fraction,
    )  # fmt: skip

    with tempfile.TemporaryDirectory(prefix="coopproc-fg-") as tmp:
        temp = Path(tmp)
        sessions = list(args.sessions)
        if not sessions:
            sessions = [REPO / p for p in DEFAULT_SESSIONS]
            sessions.append(simulated_session(temp))
        out_root = args.coopproc_out if args.coopproc_out is not None else temp / "out"
        rows = []
        for path in sessions:
            session = read_session(path)
            positions, seconds = coopproc_positions(path, out_root / path.name, args.rerun)
            fixed, g = fit(gtsam, session, opts, tuned=False)
            tuned = fixed
            if not args.no_tune:
                tuned, g = fit(gtsam, session, opts, tuned=True)
            if seconds == seconds:  # not NaN: it ran
                print(f"  coopproc run: {seconds:.1f} s ({load()})")
            for pid, times in g.times.items():
                mine = positions[
                    (positions["platform"].astype(str) == pid)
                    & (positions["time"] >= times[0] - 1e-6)
                    & (positions["time"] <= times[-1] + 1e-6)
                ]
                err = {
                    m: mean_rmse(mine.loc[mine["method"] == m, "error_h"].to_numpy(np.float64))
                    for m in ("nav", "observed")
                }
                fg = [
                    mean_rmse(horizontal_errors(session, pid, times, v[pid]))
                    for v in (fixed, tuned)
                ]
                rows.append((session.name, pid, err["nav"], err["observed"], *fg))

    print()
    print(
        f"{'session':<26} {'platform':<8} {'own nav':>8} {'coopproc':>8} {'FG fixed':>8} "
        f"{'FG ML':>8} {'coopproc/FG':>11}   rmse: {'nav':>7} {'coopproc':>8} {'FG fixed':>8} "
        f"{'FG ML':>6}"
    )
    for name, pid, nav, coop, fg_fixed, fg in rows:
        ratio = coop[0] / fg[0] if fg[0] > 0 else float("nan")
        print(
            f"{name[:26]:<26} {pid:<8} {nav[0]:8.3f} {coop[0]:8.3f} {fg_fixed[0]:8.3f} "
            f"{fg[0]:8.3f} {ratio:11.2f}         {nav[1]:7.3f} {coop[1]:8.3f} "
            f"{fg_fixed[1]:8.3f} {fg[1]:6.3f}"
        )
    print(
        "(mean horizontal error, m, against the reference over the span of the graph's "
        "states; coopproc: `observed`; FG fixed: the default odometry sigmas; FG ML: "
        "scaled by evidence; coopproc/FG: coopproc / FG ML)"
    )


if __name__ == "__main__":
    main()
