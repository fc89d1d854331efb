"""The trajectory writers of ``coopproc export`` (docs/export.md), one function a format.

TUM and KITTI are written in the session's ENU frame with six decimals (the digits of
positions.csv); RTKLIB ``.pos``, GeoJSON and KML are geodetic (WGS-84 latitude,
longitude in degrees with nine decimals, ellipsoidal height in metres with four), converted
at the session's ENU origin with pymap3d.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from coopproc import timeconv
from coopproc.frames import enu2geodetic
from coopproc.io.rtklib_pos import write_pos
from coopproc.io.tum import write_tum
from coopproc.model import FloatArray, Trajectory

__all__ = [
    "KML_NS",
    "TrackFacts",
    "write_geojson",
    "write_kitti",
    "write_kml",
    "write_pos_track",
    "write_tum_track",
]

KML_NS = "http://www.opengis.net/kml/2.2"

#: A KITTI pose: 3x4 [R | t] row by row, R the identity.
_KITTI_ROW = (
    "1.000000 0.000000 0.000000 {:.6f} 0.000000 1.000000 0.000000 {:.6f} "
    "0.000000 0.000000 1.000000 {:.6f}\n"
)


@dataclass(frozen=True, eq=False)
class TrackFacts:
    """What the GeoJSON and KML files say about a track besides its coordinates."""

    platform: str
    method: str
    time_s: FloatArray
    #: GPST seconds since the GPS epoch; None when the run's times are not absolute.
    gpst_s: FloatArray | None
    time_base: str | None

    def properties(self) -> dict[str, Any]:
        """platform, method, time base, start/end time (session seconds, UTC), epochs."""
        props: dict[str, Any] = {
            "platform": self.platform,
            "method": self.method,
            "time_base": self.time_base,
            "start_time": round(float(self.time_s[0]), 6),
            "end_time": round(float(self.time_s[-1]), 6),
            "epochs": int(self.time_s.shape[0]),
        }
        if self.gpst_s is not None:
            props["start_utc"], props["end_utc"] = (
                utc_iso(self.gpst_s[0]),
                utc_iso(self.gpst_s[-1]),
            )
        return props


def utc_iso(gpst_s: float) -> str:
    """ISO 8601 UTC time (milliseconds, ``Z``) of a GPST time (s since the GPS epoch)."""
    unix_ms = int(np.round(timeconv.gpst_to_unix(np.array([gpst_s]))[0] * 1000.0))
    return f"{np.datetime64(unix_ms, 'ms')}Z"


def write_tum_track(platform: str, time_s: FloatArray, enu_m: FloatArray, path: Path) -> Path:
    """TUM ``timestamp tx ty tz qx qy qz qw`` (identity orientation), times as in the run."""
    return write_tum(Trajectory(platform=platform, time_s=time_s, enu_m=enu_m), path)


def write_kitti(time_s: FloatArray, enu_m: FloatArray, path: Path) -> list[Path]:
    """KITTI poses (12 numbers a line) at ``path`` and their times beside it.

    The times file is ``path`` with ``.kitti.txt`` replaced by ``.times.txt`` (KITTI
    odometry's ``times.txt``; the pose file has none), in the run's time base.
    """
    times = path.with_name(path.name.removesuffix(".kitti.txt") + ".times.txt")
    with open(path, "w", encoding="utf-8") as fh:
        fh.writelines(_KITTI_ROW.format(*row) for row in enu_m)
    with open(times, "w", encoding="utf-8") as fh:
        fh.writelines(f"{t:.6f}\n" for t in time_s)
    return [path, times]


def write_pos_track(
    gpst_s: FloatArray, enu_m: FloatArray, origin: tuple[float, float, float], path: Path
) -> Path:
    """RTKLIB .pos: GPST ``week tow`` (microseconds), lat/lon/height, Q 1, sd 0 (unknown)."""
    llh = enu2geodetic(enu_m, origin)
    return write_pos(path, gpst_s, llh, time_format="week_tow", time_decimals=6)


def _coordinates(enu_m: FloatArray, origin: tuple[float, float, float]) -> list[str]:
    """``lon,lat,height`` texts of ENU points (9 decimals in degrees, 4 in metres)."""
    llh = enu2geodetic(enu_m, origin)
    return [f"{lon:.9f},{lat:.9f},{h:.4f}" for lat, lon, h in llh]


def write_geojson(
    facts: TrackFacts, enu_m: FloatArray, origin: tuple[float, float, float], path: Path
) -> Path:
    """A FeatureCollection of one Feature: a LineString (a Point for one epoch) of
    ``[lon, lat, height]`` with the track's properties; one coordinate a line."""
    coords = _coordinates(enu_m, origin)
    kind = "LineString" if len(coords) > 1 else "Point"
    marker = "@coordinates@"
    collection = {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "properties": facts.properties(),
                "geometry": {"type": kind, "coordinates": marker},
            }
        ],
    }
    text = json.dumps(collection, indent=2)
    if kind == "Point":
        body = f"[{coords[0]}]"
    else:
        body = "[\n" + ",\n".join(f"          [{c}]" for c in coords) + "\n        ]"
    path.write_text(text.replace(f'"{marker}"', body) + "\n", encoding="utf-8")
    return path


def write_kml(
    facts: TrackFacts, enu_m: FloatArray, origin: tuple[float, float, float], path: Path
) -> Path:
    """A KML document of one Placemark: a LineString (a Point for one epoch), clamped to
    the ground, with a TimeSpan when the times are absolute and the track's properties
    as ExtendedData."""
    props = facts.properties()
    kml = ET.Element("kml", xmlns=KML_NS)
    doc = ET.SubElement(kml, "Document")
    ET.SubElement(doc, "name").text = f"{facts.platform} {facts.method}"
    mark = ET.SubElement(doc, "Placemark")
    ET.SubElement(mark, "name").text = f"{facts.platform} {facts.method}"
    ET.SubElement(mark, "description").text = (
        f"coopproc export: platform {facts.platform}, method {facts.method}, "
        f"{props['epochs']} epochs, {props['start_time']}..{props['end_time']} s "
        f"({facts.time_base})"
    )
    if "start_utc" in props:
        span = ET.SubElement(mark, "TimeSpan")
        ET.SubElement(span, "begin").text = props["start_utc"]
        ET.SubElement(span, "end").text = props["end_utc"]
    extended = ET.SubElement(mark, "ExtendedData")
    for key, value in props.items():
        if value is None:
            continue
        ET.SubElement(ET.SubElement(extended, "Data", name=key), "value").text = str(value)
    coords = _coordinates(enu_m, origin)
    geometry = ET.SubElement(mark, "LineString" if len(coords) > 1 else "Point")
    if len(coords) > 1:
        ET.SubElement(geometry, "tessellate").text = "1"
    ET.SubElement(geometry, "coordinates").text = "\n".join(coords)
    tree = ET.ElementTree(kml)
    ET.indent(tree)
    tree.write(path, encoding="UTF-8", xml_declaration=True)
    with open(path, "a", encoding="utf-8") as fh:
        fh.write("\n")
    return path
