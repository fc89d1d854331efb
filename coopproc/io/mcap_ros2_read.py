"""ROS 2 (CDR) channels of an MCAP session: Odometry / NavSatFix trajectories and ranges.

Fields are read for all messages at once through :mod:`cdr_fast` when the channel's
byte layout is fixed, else message by message with the mcap_ros2 decoder; both give the
same arrays. Mapping (DATA.md, docs/formats.md): Odometry ``pose.pose.position`` = east,
north, up, pose covariance diagonal -> sigmas, orientation -> heading, twist.linear ->
ENU velocity (each "none" when all zero); NavSatFix geodetic with ``status`` -> Q
(:mod:`navsat_status`; no-fix messages left out); range
fields from ``session.toml [mcap]`` (dotted paths). Time: ``header.stamp`` where non-zero,
else the log time.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from coopproc.io import cdr_fast
from coopproc.io._common import Locator, RawTrajectory
from coopproc.io.mcap_scan import Channel
from coopproc.io.navsat_status import NAVSAT_TO_Q, navsat_quality
from coopproc.io.session_toml import McapMapping

__all__ = ["NAVSAT_TO_Q", "RosFields", "ros_range_frame", "ros_trajectory"]


class RosFields:
    """Field arrays of every message of one ROS 2 channel."""

    def __init__(self, ch: Channel, where: Locator) -> None:
        self.ch = ch
        self.where = where
        self.plan = cdr_fast.plan(ch)
        self.msgs: list[Any] = [] if self.plan is not None else self._decode()

    def _decode(self) -> list[Any]:
        ch = self.ch
        if ch.decoder is None:
            raise self.where.error(
                f"message encoding '{ch.message_encoding}' with schema '{ch.schema_name}' "
                "not supported; expected json or ROS 2 cdr with a ros2msg schema"
            )
        out = []
        for i, data in enumerate(ch.data):
            try:
                out.append(ch.decoder(data))
            except Exception as err:  # the CDR decoder raises anything on bad bytes
                raise self.where.error(
                    f"cannot decode {ch.schema_name} ({type(err).__name__}); corrupt message", i
                ) from err
        return out

    def has(self, path: str) -> bool:
        if self.plan is not None:
            return self.plan.has(path) or any(k.startswith(path + ".") for k in self.plan.fields)
        try:
            _attr(self.msgs[0], path)
        except AttributeError:
            return False
        return True

    def get(self, path: str) -> np.ndarray:
        """(n,) or (n, k) values of ``path``; ids and strings as object arrays."""
        if self.plan is not None:
            return self.plan.read(self.ch, path)
        values = [_attr(m, path) for m in self.msgs]
        if values and isinstance(values[0], str):
            return np.asarray(values, dtype=object)
        return np.asarray(values)

    def times(self) -> np.ndarray:
        """Header stamps where non-zero, else log times (seconds).

        Whole nanoseconds divided by 1e9 once: the double nearest the stamp, the same
        double a CSV time written with up to 9 decimals parses to (``sec + nsec * 1e-9``
        is off by an ulp at times).
        """
        t_ns = np.asarray(self.ch.log_time_ns, dtype=np.int64)
        if self.has("header.stamp.sec"):
            sec = self.get("header.stamp.sec").astype(np.int64)
            nsec = self.get("header.stamp.nanosec").astype(np.int64)
            stamped = (sec != 0) | (nsec != 0)
            t_ns = np.where(stamped, sec * 1_000_000_000 + nsec, t_ns)
        return t_ns / 1e9


def _attr(msg: Any, path: str) -> Any:
    value = msg
    for part in path.split("."):
        value = getattr(value, part)
    return value


def _sigma(cov_diag: np.ndarray) -> np.ndarray | None:
    return np.sqrt(np.clip(cov_diag, 0, None)) if np.any(cov_diag != 0) else None


def ros_trajectory(ch: Channel, pid: str, where: Locator) -> RawTrajectory:
    """The raw trajectory of an Odometry or NavSatFix channel."""
    name = ch.schema_name.replace("/msg/", "/")
    if name not in ("nav_msgs/Odometry", "sensor_msgs/NavSatFix"):
        raise where.error(
            f"schema {ch.schema_name}; expected nav_msgs/msg/Odometry or sensor_msgs/msg/NavSatFix"
        )
    f = RosFields(ch, where)
    time_s = f.times()
    if name == "nav_msgs/Odometry":
        p = "pose.pose.position."
        pos = np.column_stack([f.get(p + a) for a in "xyz"]).astype(np.float64)
        cov = np.asarray(f.get("pose.covariance"), dtype=np.float64)[:, [0, 7, 14]]
        o = "pose.pose.orientation."
        quat = np.column_stack([f.get(o + a) for a in "xyzw"]).astype(np.float64)
        v = "twist.twist.linear."
        vel = np.column_stack([f.get(v + a) for a in "xyz"]).astype(np.float64)
        heading = None
        if np.any(quat != 0):
            x, y, z, w = quat.T
            yaw = np.degrees(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
            heading = np.mod(90.0 - yaw, 360.0)
        return RawTrajectory(
            platform=pid,
            time_s=time_s,
            position=pos,
            form="enu",
            source=where.path,
            sigma_enu_m=_sigma(cov),
            vel_enu_mps=vel if np.any(vel != 0) else None,
            heading_deg=heading,
        )
    llh = np.column_stack([f.get(k) for k in ("latitude", "longitude", "altitude")])
    cov = np.asarray(f.get("position_covariance"), dtype=np.float64)[:, [0, 4, 8]]
    sigma = _sigma(cov)
    sigma_h = None if sigma is None else np.hypot(sigma[:, 0], sigma[:, 1])
    q = navsat_quality(
        f.get("status.status"), f.get("status.service"), sigma_h, f"{where.path} {ch.topic}"
    )
    raw = RawTrajectory(
        platform=pid,
        time_s=time_s,
        position=llh.astype(np.float64),
        form="llh",
        source=where.path,
        sigma_enu_m=sigma,
        quality=q.quality,
    )
    if not q.keep.all():
        raw = raw.take(np.flatnonzero(q.keep))
    raw.notes.extend(q.notes)
    return raw


def _ids(values: np.ndarray) -> list[str]:
    return [str(v) for v in values.tolist()]


def ros_range_frame(ch: Channel, mapping: McapMapping, where: Locator) -> pd.DataFrame:
    """The range table of a ROS 2 range channel, fields mapped by ``[mcap]``."""
    f = RosFields(ch, where)
    paths = {
        "from": mapping.from_field,
        "to": mapping.to_field,
        "range": mapping.range_field,
    }
    for name, fpath in paths.items():
        if not f.has(fpath):
            raise where.error(
                f"{ch.schema_name} has no field '{fpath}' (session.toml [mcap] "
                f"{name}_field); expected the message field holding the {name}",
                0,
            )
    n = len(ch)
    sigma = (
        f.get(mapping.sigma_field).astype(np.float64)
        if f.has(mapping.sigma_field)
        else np.full(n, np.nan)
    )
    return pd.DataFrame(
        {
            "time": f.times(),
            "from": _ids(f.get(paths["from"])),
            "to": _ids(f.get(paths["to"])),
            "range": f.get(paths["range"]).astype(np.float64),
            "sigma": sigma,
        }
    )
