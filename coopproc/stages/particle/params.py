"""Parameters of the single-auxiliary localizer (``[locate]`` table), paper 004."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["METHOD_NAMES", "LocateParams"]

#: Methods ``locate`` can run, in the order tables list them.
METHOD_NAMES: tuple[str, ...] = ("aacopf", "pf", "ekf")


@dataclass(frozen=True)
class LocateParams:
    """Every figure of ``coopproc locate``; build with ``configtools.from_table``."""

    N: int = field(
        default=400, metadata={"help": "initial positions on the range circle (paper: 400)"}
    )
    M: int = field(default=400, metadata={"help": "initial azimuths per position (paper: 400)"})
    delta_d_m: float = field(
        default=0.5, metadata={"help": "half width of the initial ring, d(1) +- delta_d, m"}
    )
    alpha: float = field(
        default=1.0, metadata={"help": "ACO weight-difference exponent alpha, eq. (14)"}
    )
    beta: float = field(
        default=1.0, metadata={"help": "ACO inverse moving-distance exponent beta, eq. (14)"}
    )
    lambda_: float = field(
        default=0.05,
        metadata={"help": "ACO threshold lambda on the best transition probability, eq. (14)"},
    )
    aco_candidates: int = field(
        default=32,
        metadata={"help": "K best particles the ACO step may move to (O(P*K) approximation)"},
    )
    aco_cell_m: float = field(
        default=0.2,
        metadata={"help": "grid cell of the ACO step's local candidates (O(P*K)), m"},
    )
    aco_weight_gate: float = field(
        default=0.001,
        metadata={"help": "only particles lighter than this x the heaviest move (ACO step)"},
    )
    ess_min: float = field(
        default=0.5,
        metadata={"help": "AACOPF: resample systematically when ESS < this x N x M (0: never)"},
    )
    Omega1: float = field(
        default=0.3, metadata={"help": "rejection threshold on |mean| of an aux's residuals, m"}
    )
    Omega2: float = field(
        default=0.04,
        metadata={"help": "rejection threshold on the variance of an aux's residuals, m^2"},
    )
    warmup: str = field(
        default="first",
        metadata={
            "help": "2+ auxiliaries before they are judged: first | quiet | floor | all "
            "(quiet: also those whose own ranges are quiet; fixed modules close by)"
        },
    )
    outlier_sigmas: float = field(
        default=1.0,
        metadata={"help": "AACOPF, 2+ auxiliaries: likelihood outlier floor until judged, sigmas"},
    )
    judge_spread_m: float = field(
        default=0.5,
        metadata={
            "help": "step 3 takes an auxiliary's residual only while the cloud predicts its "
            "range to within this (weighted 1-sigma), m"
        },
    )
    mode_keep: bool = field(
        default=False,
        metadata={
            "help": "AACOPF: keep every mode of the cloud alive until the observability "
            "analysis of the ranges used so far separates them (measured worse: off)"
        },
    )
    mode_every: int = field(
        default=5, metadata={"help": "AACOPF: epochs between two searches for modes"}
    )
    mode_min_fraction: float = field(
        default=0.005,
        metadata={"help": "AACOPF: particles a kept mode holds at least, x N x M"},
    )
    mode_cell_m: float = field(
        default=5.0, metadata={"help": "modes: grid cell in east and north, m"}
    )
    mode_az_deg: float = field(
        default=30.0, metadata={"help": "modes: grid cell in azimuth, degrees"}
    )
    mode_max: int = field(
        default=32, metadata={"help": "AACOPF: the heaviest modes kept alive (the rest free)"}
    )
    unique_weight: float = field(
        default=0.01,
        metadata={"help": "the solution is unique when the runner-up mode weighs less"},
    )
    residual_window: int = field(
        default=16, metadata={"help": "epochs of residuals behind Omega1/Omega2 (step 3)"}
    )
    range_sigma_m: float = field(
        default=0.0,
        metadata={
            "help": "ranging 1-sigma of the likelihood, m; 0: the ranges' sigma column, "
            "else session.toml [uwb] sigma, else 0.2"
        },
    )
    likelihood_floor_m: float = field(
        default=0.1,
        metadata={"help": "added in quadrature to the ranging sigma in the likelihood, m"},
    )
    step_sigma_m: float = field(
        default=0.01,
        metadata={"help": "propagation noise per axis, m per sqrt(s) (+ step_sigma_rel)"},
    )
    step_sigma_rel: float = field(
        default=0.003, metadata={"help": "propagation noise proportional to Delta L, 1-sigma"}
    )
    heading_sigma_deg: float = field(
        default=0.01,
        metadata={"help": "propagation noise on the azimuth, degrees per sqrt(s)"},
    )
    odometer_scale_sigma: float = field(
        default=0.005,
        metadata={
            "help": "prior 1-sigma of the target's odometer scale error, estimated per "
            "particle (0: eq. (3) exactly)"
        },
    )
    kernel_scale: float = field(
        default=0.4,
        metadata={"help": "AACOPF: jitter of moved particles, x the optimal kernel bandwidth"},
    )
    kernel_shrink: bool = field(
        default=True,
        metadata={
            "help": "AACOPF: Liu-West shrinkage of the kernel jitter (keeps the cloud's variance)"
        },
    )
    ekf_initial_bearing_deg: float = field(
        default=0.0,
        metadata={"help": "EKF coarse guess: bearing of the target from the aux, degrees"},
    )
    ekf_initial_azimuth_deg: float = field(
        default=0.0, metadata={"help": "EKF coarse guess: initial heading, degrees from north"}
    )
    ekf_bearings: int = field(
        default=16,
        metadata={"help": "EKF bank: initial bearings on the ring (1: one coarse guess)"},
    )
    ekf_azimuths: int = field(
        default=16,
        metadata={"help": "EKF bank: initial azimuths per bearing (1: one coarse guess)"},
    )
    azimuth_window_m: float = field(
        default=10.0,
        metadata={"help": "path length over which the reference initial azimuth is fitted, m"},
    )
    observability_tol: float = field(
        default=5e-3,
        metadata={"help": "observable when sigma_min / sigma_max of R_k exceeds this, eq. (19)"},
    )
    converge_m: float = field(
        default=1.0, metadata={"help": "converged once the error stays below this, m"}
    )
    snapshots: int = field(
        default=4, metadata={"help": "epochs at which the AACOPF particle cloud is kept"}
    )
    snapshot_particles: int = field(
        default=3000, metadata={"help": "particles kept per snapshot (a seeded subsample)"}
    )
    methods: tuple[str, ...] = field(
        default=METHOD_NAMES, metadata={"help": "methods to run: aacopf, pf, ekf"}
    )
    seed: int = field(default=0, metadata={"help": "random seed (same seed, same outputs)"})

    def __post_init__(self) -> None:
        if self.N < 1 or self.M < 1:
            raise ValueError(f"N and M must be >= 1, found N={self.N}, M={self.M}")
        if self.ekf_bearings < 1 or self.ekf_azimuths < 1:
            raise ValueError(
                f"ekf_bearings and ekf_azimuths must be >= 1, found "
                f"{self.ekf_bearings}, {self.ekf_azimuths}"
            )
        if self.aco_candidates < 1:
            raise ValueError(f"aco_candidates must be >= 1, found {self.aco_candidates}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, found {self.seed}")
        if not 0.0 <= self.lambda_ <= 1.0:
            raise ValueError(f"lambda_ must be in [0, 1], found {self.lambda_}")
        if self.residual_window < 2:
            raise ValueError(f"residual_window must be >= 2, found {self.residual_window}")
        if self.warmup not in ("first", "quiet", "floor", "all"):
            raise ValueError(f"warmup must be first, quiet, floor or all, found {self.warmup!r}")
        if self.mode_every < 1:
            raise ValueError(f"mode_every must be >= 1, found {self.mode_every}")
        if self.mode_cell_m <= 0 or self.mode_az_deg <= 0:
            raise ValueError(
                f"mode_cell_m and mode_az_deg must be > 0, found {self.mode_cell_m}, "
                f"{self.mode_az_deg}"
            )
        if self.aco_cell_m <= 0:
            raise ValueError(f"aco_cell_m must be > 0, found {self.aco_cell_m}")
        nonneg = (
            "judge_spread_m",
            "mode_min_fraction",
            "unique_weight",
            "delta_d_m",
            "odometer_scale_sigma",
            "step_sigma_m",
            "step_sigma_rel",
            "heading_sigma_deg",
        )
        for name in nonneg:
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, found {getattr(self, name)}")
        bad = [m for m in self.methods if m not in METHOD_NAMES]
        if bad or not self.methods:
            raise ValueError(f"methods must be among {', '.join(METHOD_NAMES)}, found {bad}")
