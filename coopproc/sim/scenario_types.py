"""The pieces of a scenario's world: its actors (platforms with true motion) and links.

Kept apart from the registry (:mod:`coopproc.sim.scenarios`) so that the world builders
in other modules (:mod:`coopproc.sim.aux_worlds`) can use them.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Literal

import numpy as np

from coopproc.model import FloatArray
from coopproc.sim.uwb import PairModel

__all__ = ["Actor", "NavKind", "World", "named_rng"]

NavKind = Literal["dr", "gnss", "none"]


def named_rng(seed: int, name: str) -> np.random.Generator:
    """An independent random stream per (seed, name): adding a platform leaves others alone."""
    return np.random.default_rng([seed, zlib.crc32(name.encode())])


@dataclass(frozen=True, eq=False)
class Actor:
    """One platform of a world: its role, how it navigates, and its true positions."""

    id: str
    #: "tag": no navigation of its own (nav "none"), positioned from its ranges
    role: Literal["follower", "leader", "anchor", "tag"]
    nav: NavKind
    truth_enu_m: FloatArray  # (n, 3) on the world's time grid
    #: True: the nav file is in the platform's own frame (start 0, initial heading 0).
    own_frame: bool = False
    #: (n,) body yaw (rad, counter-clockwise from east) of a body whose heading is not its
    #: course (a multirotor); None: the heading is the course over ground.
    yaw_rad: FloatArray | None = None


@dataclass(frozen=True, eq=False)
class World:
    """True motion and ranging layout of one scenario run."""

    time_rel_s: FloatArray
    actors: tuple[Actor, ...]
    links: tuple[PairModel, ...]
