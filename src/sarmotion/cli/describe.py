"""Console lines of a results document's movers: what the data fix, and what they do not.

A mover's data over a few degrees fix its ground-range coordinate (with a Cramér–Rao
standard error) and its range speed, not its cross-range position: the lines say so in
words and give the family of positions and velocities across the imaged scene
(``cross_range_family.in_scene`` of ``sarmotion.results/2``). They read the document
only (``sarmotion.results/1`` entries lack the family's members and say less).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..core.text import fixed as _num

__all__ = ["mover_lines", "not_estimated_lines"]


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
    speed = f"range speed {_num(entry['range_speed_mps'])} m/s"
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


def not_estimated_lines(doc: dict[str, Any]) -> list[str]:
    """Lines for the candidates above the threshold left unestimated by ``--max-movers``."""
    extra = doc.get("movers_not_estimated") or []
    if not extra:
        return []
    cap = doc.get("options", {}).get("max_movers")
    threshold = (doc.get("detection") or {}).get("threshold_db")
    over = f" over the threshold {_num(threshold, 1)} dB" if threshold is not None else ""
    lines = [
        f"  {len(extra)} more candidate(s) passed the detector{over}, not estimated "
        f"(--max-movers {cap}):"
    ]
    for k, c in enumerate(extra):
        lines.append(
            f"    candidate {k + 1}: statistic {_num(c['statistic_db'], 1)} dB, range "
            f"{_num(c['range_m'], 1)} m (aligned trace, not fitted), range speed "
            f"{_num(c['range_speed_mps'])} m/s"
        )
    return lines
