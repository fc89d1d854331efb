"""The stage chain of ``coopproc run`` (paper 000's processing, figure 5).

1. cooperative fusion with the observed ranges (the CP solution, paper 000 sec. 3.1.1);
2. DI smoothing, distance filtering, NLOS detection and estimation, DI- and RN-Based
   (paper 000 sec. 3.1-3.3), fed with the CP solution of step 1 (two passes: the whole
   session is fused first, then the ranges are processed; the CP increments are those of
   the causal forward filter unless ``[run] cp_solution = "smoothed"``);
3. fusion again with each processed range set (``rn``, ``di``);
4. positions of every method against the reference, and the statistics of Tables 2 and 3.

The pipeline reads no files and prints nothing; ``progress`` is called with a short label
before each step so that the CLI can show where it is.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from coopproc.model import (
    POSITIONS_COLUMNS,
    FloatArray,
    Result,
    Session,
    Trajectory,
    pair_members,
)
from coopproc.report.metrics import distance_metrics, nlos_scores, position_metrics
from coopproc.report.scores import nlos_event_scores
from coopproc.run.config import RunConfig
from coopproc.stages.fusion.calibration import FusionCalibration, calibrated_fuse
from coopproc.stages.fusion.dr_quality import DeadReckoningQuality, dead_reckoning_quality
from coopproc.stages.fusion.fuse import FusionOutput
from coopproc.stages.ranging.stage import PairCalibration, run_ranging

__all__ = ["PipelineOutput", "run_pipeline"]

#: Processed range methods that are fused again (the observed fusion is step 1).
PROCESSED_METHODS: tuple[str, ...] = ("rn", "di")


@dataclass(frozen=True, eq=False)
class PipelineOutput:
    """The result tables plus what run.json and the closing summary report."""

    result: Result
    nlos_scores: pd.DataFrame
    nlos_event_scores: pd.DataFrame
    timings_s: Mapping[str, float]
    sigma: Mapping[str, tuple[float, str]]
    #: the ranging stage's self-calibration, (pair, method) -> figures
    ranging_calibration: Mapping[tuple[str, str], PairCalibration]
    #: each fusion's self-calibration, by range method
    fusion_calibration: Mapping[str, FusionCalibration]
    #: each moving platform's dead reckoning against the observed cooperative solution
    dr_quality: Mapping[str, DeadReckoningQuality]
    notes: tuple[str, ...]


def _ranges_for(method_table: pd.DataFrame, method: str, sigma: pd.Series) -> pd.DataFrame:
    """The processed distances of one method in the shape :func:`fuse` takes."""
    rows = method_table[["time", "pair", method]].rename(columns={method: "range"})
    members = {p: pair_members(p) for p in rows["pair"].unique()}
    out = pd.DataFrame(
        {
            "time": rows["time"].to_numpy(),
            "from": [members[p][0] for p in rows["pair"]],
            "to": [members[p][1] for p in rows["pair"]],
            "range": rows["range"].to_numpy(),
            "sigma": sigma.to_numpy(),
        }
    )
    return out[np.isfinite(out["range"].to_numpy())].reset_index(drop=True)


def _positions_rows(
    session: Session,
    method: str,
    trajectories: Mapping[str, Trajectory],
) -> pd.DataFrame:
    frames = []
    for platform in sorted(trajectories):
        traj = trajectories[platform]
        error_h = np.full(len(traj), np.nan)
        ref = session.reference.get(platform)
        if ref is not None and len(ref) >= 2:
            truth = ref.interpolate_within(traj.time_s)
            error_h = np.hypot(traj.enu_m[:, 0] - truth[:, 0], traj.enu_m[:, 1] - truth[:, 1])
        frames.append(
            pd.DataFrame(
                {
                    "time": traj.time_s,
                    "platform": platform,
                    "method": method,
                    "east": traj.enu_m[:, 0],
                    "north": traj.enu_m[:, 1],
                    "up": traj.enu_m[:, 2],
                    "error_h": error_h,
                }
            )
        )
    if not frames:
        return pd.DataFrame(columns=list(POSITIONS_COLUMNS))
    return pd.concat(frames, ignore_index=True)


def _reference_rows(session: Session, like: Mapping[str, Trajectory]) -> pd.DataFrame:
    """Rows of method ``reference``: the reference trajectory at the fused output epochs
    (an extension of DATA.md's positions.csv; epochs without reference are left out)."""
    frames = []
    for platform in sorted(like):
        ref = session.reference.get(platform)
        if ref is None or len(ref) < 2:
            continue
        t = like[platform].time_s
        pos = ref.interpolate_within(t)
        ok = np.all(np.isfinite(pos), axis=1)
        frames.append(
            pd.DataFrame(
                {
                    "time": t[ok],
                    "platform": platform,
                    "method": "reference",
                    "east": pos[ok, 0],
                    "north": pos[ok, 1],
                    "up": pos[ok, 2],
                    "error_h": np.nan,
                }
            )
        )
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def _own_epochs(session: Session) -> dict[str, FloatArray]:
    """Per platform, the times of the ranges it took part in (sorted, unique)."""
    frame = session.ranges.frame
    times = frame["time"].to_numpy(dtype=np.float64)
    out = {}
    for platform in session.platform_ids:
        involved = (frame["from"] == platform).to_numpy() | (frame["to"] == platform).to_numpy()
        out[platform] = np.unique(times[involved])
    return out


def _at_own_epochs(
    trajectories: Mapping[str, Trajectory], own: Mapping[str, FloatArray] | None
) -> dict[str, Trajectory]:
    """Each platform's solution only at the epochs of its own ranges (``positions_at =
    "ranges"``): the fusion runs at every range time of the session (with staggered pair
    polling, many per second), but a platform's position is reported, and scored, at
    the epochs where it was ranged, as paper 000's 1 Hz cooperative updates are."""
    if own is None:
        return dict(trajectories)
    out = {}
    for platform, traj in trajectories.items():
        keep = np.isin(traj.time_s, own.get(platform, np.empty(0)))
        out[platform] = Trajectory(
            platform,
            traj.time_s[keep],
            traj.enu_m[keep],
            None if traj.sigma_enu_m is None else traj.sigma_enu_m[keep],
        )
    return out


def _nav_at(session: Session, like: Mapping[str, Trajectory]) -> dict[str, Trajectory]:
    """Each platform's own solution at the epochs of the fused output."""
    out = {}
    for platform, traj in like.items():
        nav = session.nav[platform]
        out[platform] = Trajectory(platform, traj.time_s, nav.interpolate(traj.time_s))
    return out


def run_pipeline(
    session: Session,
    config: RunConfig,
    progress: Callable[[str], None] | None = None,
) -> PipelineOutput:
    """Run the whole stage chain on a session (see the module docstring)."""
    step = progress or (lambda label: None)
    timings: dict[str, float] = {}

    @contextlib.contextmanager
    def timed(label: str) -> Iterator[None]:
        step(label)
        start = time.perf_counter()
        yield
        timings[label] = round(time.perf_counter() - start, 3)

    observed = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    output: Literal["ranges", "nav"] = config.run.positions_at
    fused: dict[str, FusionOutput] = {}
    fusion_cal: dict[str, FusionCalibration] = {}
    with timed("fusion (observed)"):
        fused["observed"], fusion_cal["observed"] = calibrated_fuse(
            session, observed, config.fusion, output=output
        )
        cp_fusion = fused["observed"]
        if output != "ranges":
            cp_fusion, _ = calibrated_fuse(session, observed, config.fusion, output="ranges")
    cp = cp_fusion.forward if config.run.cp_solution == "forward" else cp_fusion.smoothed

    with timed("ranging (DI, RN, NLOS)"):
        ranging = run_ranging(session, cp, config.ranging)
    table = ranging.ranges
    sigma_by_row = _row_sigma(session, table)
    for method in PROCESSED_METHODS:
        with timed(f"fusion ({method})"):
            ranges = _ranges_for(table, method, sigma_by_row)
            fused[method], fusion_cal[method] = calibrated_fuse(
                session,
                ranges,
                config.fusion,
                output=output,
                label=method,
                sigma_floor=fusion_cal["observed"].pair_sigma_m,
            )

    with timed("metrics"):
        own = _own_epochs(session) if output == "ranges" else None
        solutions = {m: _at_own_epochs(f.smoothed, own) for m, f in fused.items()}
        nav = _nav_at(session, solutions["observed"])
        parts = [
            _reference_rows(session, solutions["observed"]),
            _positions_rows(session, "nav", nav),
        ]
        for method in ("observed", *PROCESSED_METHODS):
            parts.append(_positions_rows(session, method, solutions[method]))
        positions = pd.concat(parts, ignore_index=True)
        positions = positions.sort_values(["platform", "method", "time"], kind="stable")
        positions = positions.reset_index(drop=True)[list(POSITIONS_COLUMNS)]
        sigma = dict(ranging.sigma)
        # true NLOS is labelled against the declared sigma (or, without one, the robust
        # spread of observed - reference), never against what the detector estimated
        declared = session.config.uwb_sigma_m
        label_sigma = {} if declared is None else {p: float(declared) for p in sigma}
        scores = nlos_scores(table, ranging.nlos_events, label_sigma)
        result = Result(
            ranges=table,
            di=ranging.di,
            nlos_events=ranging.nlos_events,
            nlos_estimates=ranging.nlos_estimates,
            positions=positions,
            metrics=distance_metrics(table),
            position_metrics=position_metrics(positions),
        )
    return PipelineOutput(
        result=result,
        nlos_scores=scores,
        nlos_event_scores=nlos_event_scores(table, ranging.nlos_events),
        timings_s=timings,
        sigma=sigma,
        ranging_calibration=ranging.calibration,
        fusion_calibration=fusion_cal,
        dr_quality=dead_reckoning_quality(session, fused["observed"].smoothed),
        notes=tuple(n for cal in fusion_cal.values() for n in cal.notes),
    )


def _row_sigma(session: Session, table: pd.DataFrame) -> pd.Series:
    """The UWB sigma of each row of the output range table (for the processed fusions).

    Processed ranges keep the sigma of the observed range they came from (the ranging
    stage reduces the noise, but weighting them as the raw ranges keeps the fusion
    conservative); rows without one get the session's ``[uwb] sigma`` or NaN (the fusion
    default).
    """
    obs = session.ranges.frame[["time", "pair", "sigma"]]
    merged = table[["time", "pair"]].merge(
        obs.drop_duplicates(["time", "pair"]), on=["time", "pair"], how="left"
    )
    sigma = merged["sigma"].astype(float)
    if session.config.uwb_sigma_m is not None:
        sigma = sigma.fillna(session.config.uwb_sigma_m)
    return sigma.reset_index(drop=True)
