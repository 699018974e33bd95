"""Roads from GeoJSON: LineStrings in the scene's ground coordinates (m).

A roads file is a GeoJSON document (RFC 7946 structure, parsed as plain JSON) whose
coordinates are *not* longitude/latitude but the scene's own ground coordinates
``(x, y)`` in metres (the frame of ``position_m`` everywhere in sarmotion)::

    {"type": "FeatureCollection",
     "features": [{"type": "Feature", "properties": {"name": "north road"},
                   "geometry": {"type": "LineString",
                                "coordinates": [[-40.0, -25.0], [40.0, 5.0]]}}]}

Accepted: a FeatureCollection, a Feature, a bare geometry; LineString and
MultiLineString geometries (other geometry types are skipped with a log message);
a third coordinate (height) is ignored. A feature's ``properties.name`` names its road.
UTF-8 with or without a byte-order mark.

Refused, with advice (:class:`DataError`):

* a ``crs`` member anywhere in the document (GeoJSON 2008): its coordinates are in
  that reference system, not in the scene's metres;
* longitude/latitude: RFC 7946 coordinates are degrees; a file whose roads all fit in
  a square of :data:`MIN_EXTENT_M` (1 m) a side while lying within +-180, +-90 is
  taken for degrees (a road network of less than a metre is none, and 1 m is 1e-5 deg);
* coordinates beyond :data:`MAX_COORDINATE_M` (2000 km, twice the range envelope of the
  inputs: no antenna sees further), which would overflow in the tracker;
* more than :data:`MAX_ROADS` roads or :data:`MAX_POINTS` points in all (the scene of a
  SAR aperture, a few kilometres across, holds tens of roads), a file larger than
  :data:`MAX_FILE_BYTES`, or JSON nested too deeply to parse.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..io import DataError

if TYPE_CHECKING:
    from ..tracking import Road

__all__ = ["MAX_COORDINATE_M", "MAX_FILE_BYTES", "MAX_POINTS", "MAX_ROADS", "read_roads"]

log = logging.getLogger(__name__)

#: Largest |x| or |y| of a road point (m): twice the range envelope of the inputs.
MAX_COORDINATE_M = 2e6
#: A file whose roads all fit in a square this wide (m), within +-180, +-90, is in degrees.
MIN_EXTENT_M = 1.0
#: Most roads, points in all, and bytes of a roads file.
MAX_ROADS = 1000
MAX_POINTS = 100_000
MAX_FILE_BYTES = 16 * 2**20


def read_roads(path: str | Path) -> tuple[Road, ...]:
    """The road centre lines of a GeoJSON file (module notes).

    Raises
    ------
    DataError
        Missing or unreadable file, not JSON, no LineString, or a malformed coordinate
        list; the message names the file and the feature.
    """
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: roads file not found")
    if p.stat().st_size > MAX_FILE_BYTES:
        raise DataError(
            f"{p}: {p.stat().st_size} bytes; a roads file holds at most {MAX_FILE_BYTES} "
            f"({MAX_ROADS} roads of {MAX_POINTS} points in all)"
        )
    try:
        doc = json.loads(p.read_text(encoding="utf-8-sig"))
    except RecursionError:
        raise DataError(f"{p}: not a GeoJSON (JSON) file: nested too deeply") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataError(f"{p}: not a GeoJSON (JSON) file: {exc}") from None
    _check_crs(doc, p)
    roads: list[Road] = []
    for k, (geometry, name) in enumerate(_geometries(doc, p)):
        kind = geometry.get("type") if isinstance(geometry, dict) else None
        coords = geometry.get("coordinates") if isinstance(geometry, dict) else None
        if kind == "LineString":
            lines = [coords]
        elif kind == "MultiLineString" and isinstance(coords, list):
            lines = coords
        else:
            log.info("%s: feature %d (%s) skipped: not a LineString", p, k, kind)
            continue
        for line in lines:
            roads.append(_road(line, name or f"road {k + 1}", p, k))
            if len(roads) > MAX_ROADS:
                raise DataError(f"{p}: more than {MAX_ROADS} roads (the limit of a scene)")
    if not roads:
        raise DataError(f"{p}: no LineString or MultiLineString geometry")
    points = [r.points_m for r in roads]
    if sum(len(q) for q in points) > MAX_POINTS:
        raise DataError(f"{p}: more than {MAX_POINTS} road points in all (the limit of a scene)")
    _check_degrees(points, p)
    return tuple(roads)


def _check_crs(doc: Any, p: Path) -> None:
    """DataError for a ``crs`` member of the document or of a feature."""
    feats = doc.get("features") if isinstance(doc, dict) else None
    holders = [doc] + (feats if isinstance(feats, list) else [])
    if any(isinstance(h, dict) and "crs" in h for h in holders):
        raise DataError(
            f"{p}: the GeoJSON has a 'crs' member: sarmotion reads road coordinates as the "
            "scene's ground coordinates (x, y) in metres; convert them to that frame (e.g. "
            "east, north from the scene centre) and remove 'crs'"
        )


def _check_degrees(points: list[Any], p: Path) -> None:
    """DataError for roads that are longitude/latitude (module notes)."""
    import numpy as np

    xy = np.concatenate(points)
    extent = float(np.max(np.ptp(xy, axis=0)))
    inside = bool(np.all(np.abs(xy[:, 0]) <= 180.0) and np.all(np.abs(xy[:, 1]) <= 90.0))
    if inside and extent < MIN_EXTENT_M:
        raise DataError(
            f"{p}: the roads span {extent:.3g} in x and y, like longitude/latitude in degrees "
            "(RFC 7946); sarmotion reads road coordinates as the scene's ground "
            f"coordinates in metres: convert them (roads smaller than {MIN_EXTENT_M:g} m are "
            "refused)"
        )


def _geometries(doc: Any, p: Path) -> list[tuple[Any, str]]:
    if not isinstance(doc, dict) or "type" not in doc:
        raise DataError(f"{p}: expected a GeoJSON object with a 'type', got {type(doc).__name__}")
    kind = doc["type"]
    if kind == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, list):
            raise DataError(f"{p}: FeatureCollection without a 'features' list")
    elif kind == "Feature":
        feats = [doc]
    else:
        return [(doc, "")]
    out = []
    for f in feats:
        if not isinstance(f, dict):
            raise DataError(f"{p}: a feature must be an object, got {type(f).__name__}")
        props = f.get("properties") or {}
        out.append(
            (f.get("geometry"), str(props.get("name", "")) if isinstance(props, dict) else "")
        )
    return out


def _road(line: Any, name: str, p: Path, k: int) -> Road:
    from ..tracking import Road  # Stone Soup takes ~0.9 s to import: only to read roads

    try:
        points = [[float(c[0]), float(c[1])] for c in line]
        if any(abs(v) > MAX_COORDINATE_M for q in points for v in q):
            raise ValueError(
                f"a coordinate beyond {MAX_COORDINATE_M:g} m of the scene centre (twice the "
                "range envelope)"
            )
        return Road(points_m=points, name=name)
    except (TypeError, ValueError, IndexError, KeyError, OverflowError) as exc:
        raise DataError(
            f"{p}: feature {k + 1}: coordinates must be >= 2 finite [x, y] pairs (m): {exc}"
        ) from None
