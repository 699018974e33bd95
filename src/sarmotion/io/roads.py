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
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import DataError

if TYPE_CHECKING:
    from ..tracking import Road

__all__ = ["read_roads"]

log = logging.getLogger(__name__)


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
    try:
        doc = json.loads(p.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataError(f"{p}: not a GeoJSON (JSON) file: {exc}") from None
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
    if not roads:
        raise DataError(f"{p}: no LineString or MultiLineString geometry")
    return tuple(roads)


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
        return Road(points_m=points, name=name)
    except (TypeError, ValueError, IndexError, KeyError) as exc:
        raise DataError(
            f"{p}: feature {k + 1}: coordinates must be >= 2 finite [x, y] pairs (m): {exc}"
        ) from None
