"""Console lines of a results document's movers: what the data fix, and what they do not.

A mover's data over a few degrees fix its ground-range coordinate (with a Cramér–Rao
standard error) and its range speed, not its cross-range position: the lines say so in
words and give the family of positions and velocities across the imaged scene
(``cross_range_family.in_scene`` of ``sarmotion.results/3``), and next to the range
speed its standard error (conditional on the listed member's cross range) and its span
over the family across the scene. They read the document only, whatever the number of
patches (``sarmotion.results/1`` and ``/2`` entries lack some of it and say less).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..core.text import fixed as _num

__all__ = [
    "document_lines",
    "mover_lines",
    "not_estimated_lines",
    "range_speed_words",
    "region_lines",
    "stationary_note",
]


def _pair(p: Sequence[float], digits: int = 2) -> str:
    return f"({_num(p[0], digits)}, {_num(p[1], digits)})"


def _std(v: float) -> str:
    """A standard error to two significant digits, at least to the centimetre."""
    return _num(v, 2) if v >= 0.01 else f"{float(v):.1g}"


def mover_lines(
    entry: dict[str, Any], label: str, reference: str = "the reference point"
) -> list[str]:
    """Two lines for one mover entry of a results document.

    Parameters
    ----------
    entry : dict
        A ``movers`` entry (``sarmotion.results/2``; ``/1`` lacks ``range_m`` and the
        family's members).
    label : str
        How the mover is named, e.g. ``"mover 1"``.
    reference : str
        The point its ``range_m`` is measured from, in words (a collection's mover: its
        patch's centre).
    """
    speed = range_speed_words(entry)
    if "range_m" in entry:
        rng = f"range {_num(entry['range_m'])} +- {_std(entry['range_std_m'])} m"
    else:
        rng = "range (not in this document)"
    first = f"  {label}: {rng} (ground range from {reference}), {speed}"
    fam = entry.get("cross_range_family", {}).get("in_scene")
    if entry.get("cross_range_known"):
        x, y = entry["position_m"]
        ux, uy = entry["velocity_mps"]
        return [first + f"; position {_pair((x, y))} m, velocity {_pair((ux, uy))} m/s"]
    if fam:
        p, v = fam["positions_m"], fam["velocities_mps"]
        where = (
            f"family {_pair(p[0])} m at {_pair(v[0])} m/s to {_pair(p[-1])} m at "
            f"{_pair(v[-1])} m/s across the scene"
        )
    else:
        where = "its family does not cross the imaged scene"
    second = (
        f"    cross range not determined by the data: {where}; shown at the cross range "
        f"of {reference}: {_pair(entry['position_m'])} m, {_pair(entry['velocity_mps'])} m/s"
    )
    return [first, second]


def range_speed_words(entry: dict[str, Any]) -> str:
    """``range speed U +- s m/s at the listed cross range; A-B m/s across the scene``.

    The standard error is conditional on the listed member's cross range; the span is
    the range speed of the family's members across the scene
    (``cross_range_family.range_speed_span_mps``), all of which fit the data as well.
    """
    text = f"range speed {_num(entry['range_speed_mps'])}"
    e = entry.get("standard_errors") or {}
    if "range_speed_mps" in e:
        text += f" +- {e['range_speed_mps']:.1g} m/s at the listed cross range"
    else:
        text += " m/s"
    span = (entry.get("cross_range_family") or {}).get("range_speed_span_mps")
    if span and not entry.get("cross_range_known"):
        text += f"; {_num(span[0])} to {_num(span[1])} m/s across the scene"
    return text


def _patches(doc: dict[str, Any]) -> list[dict[str, Any]]:
    return (doc.get("plan") or {}).get("patches") or []


def document_lines(doc: dict[str, Any]) -> list[str]:
    """The console's account of a results document, the same for every size.

    Each mover (:func:`mover_lines`; with several patches, its range measured from its
    kept patch's centre), the candidates left unestimated (:func:`not_estimated_lines`)
    and, for a simulated input, the truth check.
    """
    patches = _patches(doc)
    several = len(patches) > 1
    lines = region_lines(doc)
    for k, m in enumerate(doc["movers"]):
        if several:
            centre = patches[m["patch"]]["centre_m"]
            where = f"patch {m['patch']}'s centre ({centre[0]:.1f}, {centre[1]:.1f}) m"
            lines += mover_lines(m, f"mover {k + 1} (patch {m['patch']})", where)
        else:
            lines += mover_lines(m, f"mover {k + 1}")
    lines += not_estimated_lines(doc)
    if "truth" in doc:
        lines.append(
            f"  truth: {len(doc['truth'])} mover(s); {doc['false_movers']} false, "
            f"{doc['missed_movers']} missed"
        )
    return lines


def region_lines(doc: dict[str, Any]) -> list[str]:
    """The analysed region, its patches, the data's unambiguous scene and what lies outside."""
    plan = doc.get("plan") or {}
    region = doc.get("region_m")
    if not plan or region is None:
        return []
    n = len(_patches(doc))
    text = f"  region ({', '.join(_num(v, 1) for v in region)}) m (x0, y0, x1, y1): " + (
        "one patch" if n == 1 else f"{n} patches"
    )
    extent = doc.get("scene_extent_m")
    if n == 1 and extent:  # one analysis images its own square (options.analysis.image_size_m)
        x0, x1, y0, y1 = extent
        text += f", imaged ({', '.join(_num(v, 1) for v in (x0, y0, x1, y1))}) m"
    scene = plan.get("unambiguous_scene")
    if isinstance(scene, dict) and scene.get("area_m2") is not None:
        text += f"; the data's unambiguous scene {scene['area_m2']:.4g} m^2"
    outside = plan.get("outside")
    if isinstance(outside, dict) and outside.get("area_m2"):
        text += (
            f"; {outside['area_m2']:.4g} m^2 ({100.0 * outside.get('share', 0.0):.1f} %) of "
            "the declared area outside it, not analysed"
        )
    return [text]


def stationary_note(doc: dict[str, Any]) -> str:
    """The stationary listings left out: beyond the cap, sidelobes, on a mover's echo."""
    notes = []
    if doc.get("stationary_dropped"):
        notes.append(f"{doc['stationary_dropped']} beyond the cap not listed")
    if doc.get("stationary_sidelobes_dropped"):
        notes.append(
            f"{doc['stationary_sidelobes_dropped']} dropped as a brighter target's sidelobes"
        )
    if doc.get("stationary_mover_images_dropped"):
        notes.append(f"{doc['stationary_mover_images_dropped']} dropped as lying on a mover's echo")
    return f" ({', '.join(notes)})" if notes else ""


def not_estimated_lines(doc: dict[str, Any]) -> list[str]:
    """Lines for the candidates above the threshold left unestimated by ``--max-movers``."""
    extra = doc.get("movers_not_estimated") or []
    if not extra:
        return []
    opts = doc.get("options", {})
    cap = opts.get("analysis", opts).get("max_movers")
    several = len(_patches(doc)) > 1
    if several:
        lines = [
            f"  {len(extra)} more candidate(s) passed a patch's detector, not estimated "
            f"(--max-movers {cap} per patch):"
        ]
    else:
        threshold = (doc.get("detection") or {}).get("threshold_db")
        over = f" over the threshold {_num(threshold, 1)} dB" if threshold is not None else ""
        lines = [
            f"  {len(extra)} more candidate(s) passed the detector{over}, not estimated "
            f"(--max-movers {cap}):"
        ]
    for k, c in enumerate(extra):
        patch = f" (patch {c['patch']})" if several else ""
        origin = " from the patch centre" if several else ""
        lines.append(
            f"    candidate {k + 1}{patch}: statistic {_num(c['statistic_db'], 1)} dB, range "
            f"{_num(c['range_m'], 1)} m{origin} (aligned trace, not fitted), range speed "
            f"{_num(c['range_speed_mps'])} m/s"
        )
    return lines
