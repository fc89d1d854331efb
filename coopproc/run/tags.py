"""Platforms without dead reckoning (role ``tag``) in the stage chain.

A tag has no navigation of its own (DATA.md "Raw sensors"): only the UWB-only position
estimators (``uwb_only``: ``lsq``, ``lsq_kf``, ``lsq_rts``) can position it. The range
processors (DI smoothing, RN, NLOS: they need dead reckoning at both ends of a pair) and
the cooperative fusion (it needs every moving platform's navigation) run on the session
without its tags and without the ranges of pairs with a tag; the tag pairs' rows of
ranges.csv keep their observed range and have no processed value. When the configured
chain has no UWB-only estimator, ``lsq`` and ``lsq_rts`` are added; when no platform
with navigation is left, the chain is only those. A platform with navigation that ranges
to anchors gets them too, as comparison rows (:func:`anchor_pipeline`). Every such
decision is a note.

A session without tags passes through unchanged (the same objects), so its outputs are
those of a run without this module.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from coopproc.model import Session, pair_members
from coopproc.run.chain import PipelineParams
from coopproc.stages.base import RangeProduct
from coopproc.stages.registry import POSITION_STAGES

__all__ = [
    "ANCHOR_METHODS",
    "TAG_METHODS",
    "anchor_pipeline",
    "tag_ids",
    "tag_pipeline",
    "tag_rows",
    "widen",
    "without_tags",
]

#: The estimators added when tags are there and the chain has no UWB-only one: the fixes,
#: their smoother, and the range-by-range smoother (which needs no simultaneous ranges).
TAG_METHODS: tuple[str, ...] = ("lsq", "lsq_rts", "range_rts")
#: The comparison rows added for platforms with navigation that range to anchors.
ANCHOR_METHODS: tuple[str, ...] = ("lsq", "lsq_rts")


def tag_ids(session: Session) -> list[str]:
    """The platforms with role ``tag``, in session order."""
    return [p for p in session.platform_ids if session.platforms[p].role == "tag"]


def tag_rows(session: Session, pairs: pd.Series) -> np.ndarray:
    """True for the rows whose pair (``A-B``) has a tag at one end."""
    tags = set(tag_ids(session))
    codes, names = pd.factorize(pairs)
    has_tag = np.array([bool(set(pair_members(str(p))) & tags) for p in names], dtype=bool)
    return has_tag[codes] if len(names) else np.zeros(len(pairs), dtype=bool)


def without_tags(session: Session) -> Session:
    """The session without its tags and the ranges of pairs with a tag (itself if none)."""
    tags = set(tag_ids(session))
    if not tags:
        return session
    frame = session.ranges.frame
    keep = ~(frame["from"].isin(tags) | frame["to"].isin(tags)).to_numpy()
    ranges = dataclasses.replace(session.ranges, frame=frame[keep].reset_index(drop=True))
    platforms = {p: v for p, v in session.platforms.items() if p not in tags}
    return dataclasses.replace(session, platforms=platforms, ranges=ranges)


def tag_pipeline(params: PipelineParams, session: Session) -> tuple[PipelineParams, list[str]]:
    """The chain for a session with tags, and the notes saying what changed and why."""
    tags = tag_ids(session)
    if not tags:
        return params, []
    named = ", ".join(tags)
    notes = []
    positions = params.positions
    if not any(POSITION_STAGES[n].uwb_only for n in positions):
        positions = (*positions, *TAG_METHODS)
        notes.append(
            f"tag {named} (no navigation of its own): UWB-only positioning "
            f"{', '.join(TAG_METHODS)} added to [pipeline] positions"
        )
    navigating = [p for p, v in session.platforms.items() if v.role in ("follower", "leader")]
    dr_needing = [n for n in positions if not POSITION_STAGES[n].uwb_only]
    if not navigating and (dr_needing or params.ranges):
        skipped = [*dr_needing, *params.ranges]
        notes.append(
            f"no platform with navigation: {', '.join(skipped)} not run (they need dead "
            "reckoning); tags are positioned from their ranges to anchors only"
        )
        positions = tuple(n for n in positions if POSITION_STAGES[n].uwb_only)
        return dataclasses.replace(params, ranges=(), positions=positions), notes
    if dr_needing or params.ranges:
        notes.append(
            f"pairs with tag {named} are left out of "
            f"{', '.join([*dr_needing, *params.ranges])} (they need dead reckoning at both "
            "ends); only the UWB-only methods use them"
        )
    return dataclasses.replace(params, positions=positions), notes


def anchor_pipeline(params: PipelineParams, session: Session) -> tuple[PipelineParams, list[str]]:
    """The chain with the UWB-only methods (:data:`ANCHOR_METHODS`) as comparison rows when
    a platform with navigation ranges to anchors (paper 003 Table 1's "UWB LS" row next
    to its UWB/INS rows), unless one is named already or ``[pipeline] anchor_methods =
    false``; the note saying so. The other methods' rows are untouched (new rows only)."""
    anchors = {p for p, v in session.platforms.items() if v.role == "anchor"}
    if not params.anchor_methods or not anchors:
        return params, []
    if any(n in (*TAG_METHODS, *ANCHOR_METHODS) for n in params.positions):
        return params, []
    frame = session.ranges.frame
    ends = frame["from"].where(
        frame["to"].isin(anchors), frame["to"].where(frame["from"].isin(anchors))
    )
    navigating = sorted(
        p for p in set(ends.dropna()) - anchors if session.platforms.get(p) is not None
        and session.platforms[p].role in ("follower", "leader")
    )  # fmt: skip
    if not navigating:
        return params, []
    added = list(ANCHOR_METHODS)
    note = (
        f"{', '.join(navigating)}: ranges to anchors: UWB-only {', '.join(added)} added to "
        "[pipeline] positions as comparison rows, on the observed ranges "
        "([pipeline] anchor_methods = false: not)"
    )
    only = (*params.observed_only, *added)
    return dataclasses.replace(params, positions=(*params.positions, *added), observed_only=only), [
        note
    ]


def widen(product: RangeProduct, rows: np.ndarray) -> RangeProduct:
    """A range processor's product on the rows without tags, spread over every row
    (``rows``: True for the rows it saw); the others get NaN / no NLOS."""
    n = rows.shape[0]

    def spread(values: np.ndarray, fill: float) -> np.ndarray:
        out = np.full(n, fill, dtype=np.asarray(values).dtype)
        out[rows] = values
        return out

    values = {m: spread(np.asarray(v, dtype=np.float64), np.nan) for m, v in product.values.items()}
    nlos = {
        m: (spread(np.asarray(f), 0), spread(np.asarray(e, dtype=np.float64), 0.0))
        for m, (f, e) in product.nlos.items()
    }
    outlier = None if product.outlier is None else spread(np.asarray(product.outlier), 0)
    fusion_values = {
        m: spread(np.asarray(v, dtype=np.float64), np.nan) for m, v in product.fusion_values.items()
    }
    return dataclasses.replace(
        product, values=values, nlos=nlos, outlier=outlier, fusion_values=fusion_values
    )
