"""Names fixed by the data contract: the columns of the output tables and of the range
table (DATA.md "Output"), and the name of a platform pair.

The single source of those names; :mod:`coopproc.model` re-exports them.
"""

from __future__ import annotations

__all__ = [
    "DI_COLUMNS",
    "DR_STATES_COLUMNS",
    "METHODS",
    "METRICS_COLUMNS",
    "NLOS_ESTIMATE_COLUMNS",
    "NLOS_EVENT_COLUMNS",
    "POSITIONS_COLUMNS",
    "POSITION_METRICS_COLUMNS",
    "RANGES_OUT_COLUMNS",
    "RANGE_COLUMNS",
    "RANGE_WEIGHTS_COLUMNS",
    "STATES_COLUMNS",
    "pair_members",
    "pair_name",
]

#: Range-processing methods, in the order tables list them.
METHODS: tuple[str, ...] = ("observed", "rn", "di")

#: Columns of the in-memory range table (``RangeTable.frame``); extra columns follow.
RANGE_COLUMNS: tuple[str, ...] = ("time", "pair", "from", "to", "range", "sigma")

# Output tables (DATA.md "Output").
RANGES_OUT_COLUMNS: tuple[str, ...] = (
    "time",
    "pair",
    "observed",
    "rn",
    "di",
    "reference",
    "nlos_flag",
    "nlos_estimate",
    "outlier",
)
DI_COLUMNS: tuple[str, ...] = ("time", "pair", "di_dr", "di_cp", "di_smoothed", "di_reference")
NLOS_EVENT_COLUMNS: tuple[str, ...] = ("pair", "method", "start", "end", "epochs", "estimate")
#: Extension of DATA.md: the NLOS estimate after each step of eq. (11) (paper 000 fig. 10).
NLOS_ESTIMATE_COLUMNS: tuple[str, ...] = ("pair", "method", "event", "step", "time", "estimate")
POSITIONS_COLUMNS: tuple[str, ...] = (
    "time",
    "platform",
    "method",
    "east",
    "north",
    "up",
    "error_h",
)
METRICS_COLUMNS: tuple[str, ...] = (
    "pair",
    "method",
    "max",
    "mean",
    "rmse",
    "snr_db",
    "smoothness",
    "n",
)
POSITION_METRICS_COLUMNS: tuple[str, ...] = ("platform", "method", "max", "mean", "rmse", "n")
#: states.csv (DATA.md): velocity (m/s, ENU) and attitude (deg; roll right side down,
#: pitch nose up, yaw = heading clockwise from north) of the methods that estimate them.
_STATE_VALUES = ("vel_east", "vel_north", "vel_up", "roll", "pitch", "yaw")
STATES_COLUMNS: tuple[str, ...] = ("time", "platform", "method", *_STATE_VALUES)
STATES_COLUMNS += tuple(f"sigma_{c}" for c in _STATE_VALUES)
#: dr_states.csv (docs/outputs.md): the cooperative fusion's estimate of each follower's
#: dead-reckoning errors ([fusion] state = "dr"): heading error (deg, clockwise from north
#: like states.csv's yaw: DR heading minus true), heading-rate error (deg/h, the gyro bias
#: as the heading sees it) and odometer scale error (0.01 = the DR steps 1 % too long),
#: with their 1-sigma, of the smoothed solution.
_DR_VALUES = ("heading_error", "heading_rate_error", "scale_error")
DR_STATES_COLUMNS: tuple[str, ...] = ("time", "platform", "method", *_DR_VALUES)
DR_STATES_COLUMNS += tuple(f"sigma_{c}" for c in _DR_VALUES)

#: range_weights.csv (docs/outputs.md, extension): each range a cooperative fusion method
#: used, with the IGG-III decision of the pass whose solution it reports: ``innovation``
#: the residual the factor judged (m; the innovation at the prior, or with the robust
#: smoother the residual against the smoothed solution), ``standardized`` that over its
#: sigma and the MAD unit-weight sigma, ``gamma`` the factor (1 full weight, 0 rejected),
#: ``rejected`` 1 beyond k1.
RANGE_WEIGHTS_COLUMNS: tuple[str, ...] = (
    "time",
    "pair",
    "method",
    "innovation",
    "standardized",
    "gamma",
    "rejected",
)

#: lsq_quality.csv (docs/outputs.md, extension): every epoch of a platform's ranges to
#: anchors that the ``lsq*`` methods solved (coopproc.stages.anchors.anchor_lsq): the
#: anchors in it, HDOP / VDOP (unit weight; VDOP empty for a fix at one height), the
#: chi-square of the robust standardized residuals with ``dof`` degrees of freedom, the
#: height used (m), and ``status``: ok (a fix) or why it was dropped (dop, residual,
#: mirror, diverged).
LSQ_QUALITY_COLUMNS: tuple[str, ...] = (
    "time",
    "platform",
    "method",
    "anchors",
    "hdop",
    "vdop",
    "chi2",
    "dof",
    "up",
    "status",
)


def pair_name(a: str, b: str) -> str:
    """The unordered pair of two platform ids, ``A-B`` with the ids in sorted order."""
    first, second = sorted((a, b))
    return f"{first}-{second}"


def pair_members(pair: str) -> tuple[str, str]:
    """The two platform ids of a pair name made by :func:`pair_name`.

    Ids may contain ``-``; the split is the one whose halves are in sorted order, which
    is unique for names made by :func:`pair_name` when ids have no ``-`` and the first
    such split otherwise.
    """
    parts = pair.split("-")
    for i in range(1, len(parts)):
        a, b = "-".join(parts[:i]), "-".join(parts[i:])
        if a <= b:
            return a, b
    raise ValueError(f"not a pair name: {pair!r}")
