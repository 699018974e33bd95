"""Why a track ends where it does: the data's end, the imaged scene's edge, or no detection.

A track's last detection is in sub-aperture ``k``. If ``k`` is the last sub-aperture,
the data end there (``"data"``). Otherwise the mover, moving on uniformly from its last
state, is at ``p = position + velocity (t_next - t_k)`` at the next sub-aperture's time
``t_next``; each sub-aperture images a rectangle of half-sides ``h_x, h_y`` about its
grid's centre ``c``, and a mover outside it is in no sub-aperture's image
(``"left_scene"``: a larger ``--size``, or the collection path, follows it further).

The data fix a mover's range, not its place along the cross-range family, unless a road
or the looks fix it (:mod:`sarmotion.tracking.wide_aspect`). With its cross range not
fixed, the mover has left only if no place along the family at its range is inside:
its ground-range offset ``a = (p - c) . e_r`` (``e_r`` the next sub-aperture's ground
range direction) beyond ``h_x |e_r,x| + h_y |e_r,y|``, the rectangle's half-extent
along ``e_r``. With its position fixed, ``p`` outside the rectangle. Else the reason is
``"not_detected"``: the mover was not found in a sub-aperture whose image holds it (or,
its cross range not fixed, it may have left across the family: the data do not tell).

Times in s of the whole acquisition's slow time, positions in m.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["TrackEnd", "track_end"]


@dataclass(frozen=True, kw_only=True)
class TrackEnd:
    """Why a track ends (module notes).

    Attributes
    ----------
    reason : {"data", "left_scene", "not_detected"}
        The data end at its last detection; the mover, moving on uniformly, is outside
        the imaged scene at the next sub-aperture; or it is not detected there.
    time_s : float
        Time of its last detection (s).
    next_time_s : float or None
        The next sub-aperture's time (s); None for ``"data"``.
    predicted_position_m : (2,) ndarray or None
        Where uniform motion puts it then (m); its cross range is the family's unless
        ``fixed``.
    range_offset_m : float or None
        Its ground-range offset from the image's centre then (m).
    range_half_extent_m : float or None
        The image's half-extent along that ground range (m).
    fixed : bool
        Its position was fixed (a road or the looks), not only its range.
    """

    reason: str
    time_s: float
    next_time_s: float | None = None
    predicted_position_m: NDArray[np.float64] | None = None
    range_offset_m: float | None = None
    range_half_extent_m: float | None = None
    fixed: bool = False

    def describe(self) -> str:
        """One line for the console and the report."""
        if self.reason == "data":
            return f"ends with the data (last detection at {self.time_s:.2f} s)"
        if self.reason == "left_scene":
            if self.fixed:
                x, y = self.predicted_position_m
                where = f"predicted at ({x:.1f}, {y:.1f}) m, outside the image,"
            else:
                where = (
                    f"{abs(self.range_offset_m or 0.0):.1f} m from the centre in ground range, "
                    f"the image reaching {self.range_half_extent_m:.1f} m,"
                )
            return (
                f"left the imaged scene after {self.time_s:.2f} s ({where} at "
                f"{self.next_time_s:.2f} s): a larger --size or the collection path "
                "follows it further"
            )
        return f"not detected after {self.time_s:.2f} s, while still in the imaged scene" + (
            "" if self.fixed else " in range (it may have left across its family)"
        )


def track_end(
    *,
    last_time_s: float,
    last_index: int,
    position_m: NDArray[np.float64],
    velocity_mps: NDArray[np.float64],
    fixed: bool,
    sub_apertures: Sequence[tuple[int, float, NDArray[np.float64], tuple[float, ...]]],
) -> TrackEnd:
    """Why a track whose last detection is in sub-aperture ``last_index`` ends there.

    Parameters
    ----------
    last_time_s : float
        Time of the last detection (s).
    last_index : int
        Its sub-aperture's index.
    position_m, velocity_mps : (2,) ndarray
        The track's state at the last detection (m, m/s).
    fixed : bool
        Its position is fixed (a road or the looks), not only its range.
    sub_apertures : sequence of (index, time_s, range_direction, (cx, cy, hx, hy))
        Every sub-aperture of the pass in time order: its index, centre time (s), ground
        range direction ``e_r`` (2,), and its image's centre and half-sides (m).

    Returns
    -------
    TrackEnd
    """
    later = [s for s in sub_apertures if s[0] > last_index]
    if not later:
        return TrackEnd(reason="data", time_s=float(last_time_s), fixed=fixed)
    _, t_next, e_r, (cx, cy, hx, hy) = later[0]
    p = np.asarray(position_m, float) + np.asarray(velocity_mps, float) * (t_next - last_time_s)
    e_r = np.asarray(e_r, float)
    offset = float((p - np.array([cx, cy])) @ e_r)
    half = float(hx * abs(e_r[0]) + hy * abs(e_r[1]))
    if fixed:
        outside = abs(p[0] - cx) > hx or abs(p[1] - cy) > hy
    else:
        outside = abs(offset) > half
    return TrackEnd(
        reason="left_scene" if outside else "not_detected",
        time_s=float(last_time_s),
        next_time_s=float(t_next),
        predicted_position_m=p,
        range_offset_m=offset,
        range_half_extent_m=half,
        fixed=fixed,
    )
