"""Figures in the paper's style. The only module that imports matplotlib.

Trace matrices are shown as ``|M|`` normalised by ``max |M|`` of the data they were
separated from (the paper's convention), optionally in dB; slow time ``s`` (s) on the
vertical axis and fast time ``t`` (ns) on the horizontal axis. Images are shown in dB
relative to their peak, with ground coordinates in metres.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.text import Annotation, Text
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "LEGEND_PT",
    "LEGIBLE_PT",
    "LOOK_ARROW_GID",
    "LOOK_LABEL",
    "CSS_PX_PER_IN",
    "displayed_pt",
    "draw_look_arrow",
    "smallest_text_pt",
    "saved_width_px",
    "fit_to_column",
    "plot_traces",
    "subplots",
    "plot_image",
    "traces_figure",
    "image_figure",
    "full_resolution_image_figure",
    "save_figure",
    "to_db",
]


#: Font size of every legend (pt): the least that reads as 8 pt in the reports, whose
#: figures are drawn at 100 to 110 dpi and shown at about their size.
LEGEND_PT = 8.0

#: Least size (CSS pt) of any text of a figure as a page shows it.
LEGIBLE_PT = 8.0

#: CSS pixels per inch (CSS 2.1: 1 in = 96 px = 72 pt): a browser shows a PNG at one
#: CSS pixel per PNG pixel unless the page scales it.
CSS_PX_PER_IN = 96.0


def displayed_pt(size_pt: float, *, dpi: float, width_px: float, column_px: float) -> float:
    """Size (CSS pt) of ``size_pt`` text of a PNG saved at ``dpi`` as a page's column shows it.

    A point of the figure is ``dpi / 72`` PNG pixels; the page shows the PNG at one CSS
    pixel per PNG pixel, scaled down to the column when wider (``min(1, column_px /
    width_px)``, as ``max-width: 100%`` does); a CSS point is ``96 / 72`` CSS pixels. So
    ``size_pt * dpi / 96 * min(1, column_px / width_px)``.

    Parameters
    ----------
    size_pt : float
        Font size in the figure (pt).
    dpi : float
        Resolution the PNG was saved at (PNG pixels per inch).
    width_px : float
        Width of the PNG (pixels).
    column_px : float
        Width of the page's column (CSS px).
    """
    return float(size_pt) * float(dpi) / CSS_PX_PER_IN * min(1.0, column_px / width_px)


def smallest_text_pt(fig: Figure) -> float:
    """Smallest font size (pt) of the text drawn in ``fig``.

    Every visible, non-empty text (tick labels, axis labels, titles, legends, colour bar
    labels, annotations) of the visible axes and of the figure, once the figure is laid
    out (tick labels exist only then). ``inf`` for a figure without text.
    """
    fig.draw_without_rendering()
    sizes = [
        t.get_fontsize()
        for t in fig.findobj(Text)
        if t.get_visible() and t.get_text().strip() and (t.axes is None or t.axes.get_visible())
    ]
    return float(min(sizes, default=np.inf))


def saved_width_px(fig: Figure, *, dpi: float, tight: bool = True) -> int:
    """Width (pixels) of the PNG that :func:`save_figure` writes of ``fig`` at ``dpi``."""
    buf = io.BytesIO()
    if tight:
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight", pad_inches=0.1)
    else:
        fig.savefig(buf, format="png", dpi=dpi)
    # PNG: 8-byte signature, then the IHDR chunk (length, type, width, height)
    return int.from_bytes(buf.getvalue()[16:20], "big")


def fit_to_column(
    fig: Figure, *, dpi: float, column_px: float, min_pt: float = LEGIBLE_PT
) -> float:
    """Shrink ``fig`` until its smallest text shows at ``min_pt`` or more in the column.

    A figure wider than the column is shown scaled down (:func:`displayed_pt`), and its
    text with it. Shrinking the figure (then laying it out again with ``tight_layout``)
    keeps its text at its size in points while the panels get smaller, so the PNG
    (saved tight at ``dpi``) needs less scaling. The text does not shrink with the
    figure, so one step of the ratio ``shown / min_pt`` can leave it short: it repeats
    until legible. A figure already legible is left as it is. For figures laid out with
    ``tight_layout`` (the paper's).

    Returns
    -------
    float
        The smallest text's displayed size (CSS pt).
    """
    smallest = smallest_text_pt(fig)
    shown = np.inf
    for _ in range(12):
        width = saved_width_px(fig, dpi=dpi)
        shown = displayed_pt(smallest, dpi=dpi, width_px=width, column_px=column_px)
        if shown >= min_pt:
            break
        w, h = fig.get_size_inches()
        r = 0.99 * shown / min_pt  # 1 % under the ratio: fewer repeats, never above it
        fig.set_size_inches(w * r, h * r)
        fig.tight_layout()
    return float(shown)


#: Label of the look-direction arrow (:func:`draw_look_arrow`).
LOOK_LABEL = "radar look"

#: ``gid`` of the arrow :func:`draw_look_arrow` draws (to find it among the artists).
LOOK_ARROW_GID = "look-direction"


def draw_look_arrow(
    ax: Axes,
    direction: ArrayLike,
    *,
    label: str = LOOK_LABEL,
    where: tuple[float, float] = (0.13, 0.2),
    length: float = 0.14,
) -> Annotation:
    """An arrow along the radar's look direction on the ground, in a corner of ``ax``.

    The arrow points from the radar towards the scene, on the ground: minus the range
    direction ``e_r`` of the results document's ``frame`` (``e_r`` points towards the
    antenna, docs/results.md). It is drawn in data coordinates (x, y in metres), so its
    direction is the look direction whatever the axes' aspect; white with a black edge,
    to show on a dark or a bright image, with ``label`` under it. Call it once the axes'
    limits are final: its place is taken from them.

    Parameters
    ----------
    ax : Axes
        Axes of a ground image (x, y in metres).
    direction : (2,) array_like
        Ground direction from the radar towards the scene (any length, not zero).
    label : str
        Text under the arrow.
    where : (float, float)
        Centre of the arrow (fractions of the axes' width and height).
    length : float
        Length of the arrow (fraction of the shorter side of the axes' data box).

    Returns
    -------
    Annotation
        The arrow: ``xyann`` its tail, ``xy`` its head (data coordinates); its ``gid`` is
        :data:`LOOK_ARROW_GID`.
    """
    d = np.asarray(direction, dtype=np.float64)[:2]
    norm = float(np.hypot(*d))
    if not (np.isfinite(norm) and norm > 0):
        raise ValueError(f"direction must be a finite non-zero ground vector, got {direction!r}")
    d = d / norm
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    centre = np.array([x0 + where[0] * (x1 - x0), y0 + where[1] * (y1 - y0)])
    half = 0.5 * length * min(abs(x1 - x0), abs(y1 - y0))
    arrow = ax.annotate(
        "",
        xy=tuple(centre + half * d),
        xytext=tuple(centre - half * d),
        arrowprops={
            "arrowstyle": "simple,head_width=0.7,head_length=0.7,tail_width=0.25",
            "fc": "w",
            "ec": "k",
            "lw": 0.8,
            "shrinkA": 0,
            "shrinkB": 0,
        },
        annotation_clip=False,
        zorder=6,
    )
    arrow.set_gid(LOOK_ARROW_GID)
    ax.annotate(
        label,
        xy=(centre[0], centre[1] - half),
        xytext=(0, -4),
        textcoords="offset points",
        ha="center",
        va="top",
        fontsize=LEGEND_PT,
        bbox={"boxstyle": "round,pad=0.2", "fc": "w", "ec": "none", "alpha": 0.85},
        annotation_clip=False,
        zorder=6,
    )
    return arrow


def to_db(
    values: ArrayLike, *, reference: float | None = None, floor_db: float = -120.0
) -> NDArray:
    """``20 log10(|values| / reference)`` with a floor (dB); reference defaults to the max."""
    a = np.abs(np.asarray(values))
    ref = float(a.max()) if reference is None else float(reference)
    if ref <= 0:
        return np.full(a.shape, floor_db)
    with np.errstate(divide="ignore"):
        out = 20.0 * np.log10(a / ref)
    return np.maximum(out, floor_db)


def plot_traces(
    ax: Axes,
    data: ArrayLike,
    *,
    slow_times_s: ArrayLike,
    fast_times_s: ArrayLike,
    normalise_by: float | None = None,
    db: bool = False,
    dynamic_range_db: float = 60.0,
    title: str = "",
    colorbar: bool = True,
    reference_label: str = "max|M|",
) -> None:
    """Draw ``|data|`` (n_pulses, n_samples) normalised by ``normalise_by`` (default its max).

    Parameters
    ----------
    ax : matplotlib Axes
        Target axes.
    data : (n_pulses, n_samples) array_like
        Traces.
    slow_times_s, fast_times_s : array_like
        Axes (s).
    normalise_by : float, optional
        Normalisation, usually ``max |M|`` of the unseparated data.
    db : bool
        Plot ``20 log10`` of the normalised modulus, clipped at ``-dynamic_range_db``.
    reference_label : str
        What ``normalise_by`` is, for the colour bar (``"max|M|"``: the unseparated data).
    """
    d = np.abs(np.asarray(data))
    ref = float(d.max()) if normalise_by is None else float(normalise_by)
    s = np.asarray(slow_times_s)
    t = np.asarray(fast_times_s) * 1e9
    extent = (t[0], t[-1], s[-1], s[0])
    if db:
        img = to_db(d, reference=ref, floor_db=-dynamic_range_db)
        im = ax.imshow(
            img,
            aspect="auto",
            extent=extent,
            cmap="viridis",
            vmin=-dynamic_range_db,
            vmax=0.0,
            interpolation="nearest",
        )
        label = f"dB re {reference_label}"
    else:
        img = d / ref if ref > 0 else d
        im = ax.imshow(
            img,
            aspect="auto",
            extent=extent,
            cmap="viridis",
            vmin=0.0,
            vmax=1.0,
            interpolation="nearest",
        )
        label = f"|.| / {reference_label}"
    ax.set_xlabel("fast time t (ns)")
    ax.set_ylabel("slow time s (s)")
    if title:
        ax.set_title(title, fontsize=9)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, label=label, fraction=0.046, pad=0.04)


def plot_image(
    ax: Axes,
    values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    dynamic_range_db: float = 40.0,
    reference: float | None = None,
    title: str = "",
    markers: Sequence[tuple[float, float]] = (),
    marker_label: str = "",
    colorbar: bool = True,
    look_direction: ArrayLike | None = None,
) -> None:
    """Draw an image ``|I|`` (ny, nx) in dB re its peak (or ``reference``), axes in metres.

    ``markers`` are ground positions (m) drawn as open circles (e.g. true positions).
    ``look_direction``, the ground direction from the radar towards the scene, is drawn
    as an arrow (:func:`draw_look_arrow`).
    """
    x = np.asarray(x_m)
    y = np.asarray(y_m)
    img = to_db(values, reference=reference, floor_db=-dynamic_range_db)
    im = ax.imshow(
        img,
        origin="lower",
        extent=(x[0], x[-1], y[0], y[-1]),
        cmap="gray",
        vmin=-dynamic_range_db,
        vmax=0.0,
        interpolation="nearest",
    )
    if markers:
        mx, my = np.asarray(markers, dtype=float).T
        ax.plot(mx, my, "o", mfc="none", mec="tab:red", ms=8, mew=1.0, label=marker_label or None)
        if marker_label:
            ax.legend(loc="upper right", fontsize=LEGEND_PT)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    if title:
        ax.set_title(title, fontsize=9)
    if look_direction is not None:
        draw_look_arrow(ax, look_direction)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, label="dB", fraction=0.046, pad=0.04)


def traces_figure(
    panels: Sequence[
        tuple[str, ArrayLike, bool]
        | tuple[str, ArrayLike, bool, float | None]
        | tuple[str, ArrayLike, bool, float | None, str]
    ],
    *,
    slow_times_s: ArrayLike,
    fast_times_s: ArrayLike,
    normalise_by: float | None = None,
    ncols: int | None = None,
    dynamic_range_db: float = 60.0,
    fast_slice: slice | None = None,
) -> Figure:
    """A row (or grid) of trace panels ``(title, data, in_db[, normalise_by[, label]])``.

    Panels share ``normalise_by`` (default: the largest ``|data|`` of all panels) unless
    a panel gives its own as a fourth element, and a fifth names it on the colour bar
    (default ``"max|M|"``). ``fast_slice`` selects a fast-time window
    of every panel.
    """
    n = len(panels)
    ncols = ncols or n
    nrows = int(np.ceil(n / ncols))
    fig, axes = subplots(nrows, ncols, figsize=(4.2 * ncols, 3.6 * nrows), squeeze=False)
    shared = normalise_by
    if shared is None:
        shared = max(float(np.abs(np.asarray(p[1])).max()) for p in panels)
    sl = fast_slice if fast_slice is not None else slice(None)
    for ax, panel in zip(axes.ravel(), panels, strict=False):
        title, data, db = panel[:3]
        ref = panel[3] if len(panel) > 3 else shared
        ref_label = panel[4] if len(panel) > 4 else "max|M|"
        plot_traces(
            ax,
            np.asarray(data)[:, sl],
            slow_times_s=slow_times_s,
            fast_times_s=np.asarray(fast_times_s)[sl],
            normalise_by=ref,
            db=db,
            title=title,
            dynamic_range_db=dynamic_range_db,
            reference_label=ref_label,
        )
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.tight_layout()
    return fig


def image_figure(
    panels: Sequence[tuple[str, ArrayLike]],
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    dynamic_range_db: float = 40.0,
    common_reference: bool = False,
    markers: Sequence[Sequence[tuple[float, float]]] | None = None,
    look_direction: ArrayLike | None = None,
) -> Figure:
    """A row of image panels ``(title, values)`` in dB; optionally one common reference.

    ``look_direction`` (ground direction from the radar towards the scene): an arrow on
    each panel (:func:`draw_look_arrow`).
    """
    n = len(panels)
    fig, axes = subplots(1, n, figsize=(4.6 * n, 4.0), squeeze=False)
    ref = None
    if common_reference:
        ref = max(float(np.abs(np.asarray(v)).max()) for _, v in panels)
    for k, (ax, (title, values)) in enumerate(zip(axes[0], panels, strict=True)):
        mk = markers[k] if markers is not None else ()
        plot_image(
            ax,
            values,
            x_m=x_m,
            y_m=y_m,
            dynamic_range_db=dynamic_range_db,
            reference=ref,
            title=title,
            markers=mk,
            look_direction=look_direction,
        )
    fig.tight_layout()
    return fig


def full_resolution_image_figure(
    values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    title: str,
    dynamic_range_db: float = 40.0,
    dpi: int = 100,
    min_side_px: int = 400,
    look_direction: ArrayLike | None = None,
) -> Figure:
    """One image ``|I|`` (ny, nx) in dB re its peak, drawn with whole screen pixels per pixel.

    Saved at ``dpi`` (:func:`save_figure` with the same ``dpi``, or
    ``fig.savefig(..., dpi=dpi)``), the image area is ``k nx`` by ``k ny`` PNG pixels:
    every image pixel is a ``k x k`` block, ``k`` the smallest integer that makes the
    longer side at least ``min_side_px`` (1 for an image already that large): nothing is
    resampled away. The figure keeps fixed margins (inches) around it for the axes, the
    colour bar and the title, and is at least wide enough for a three-line title.

    Parameters
    ----------
    values : (ny, nx) array_like
        The image (any complex or real values; drawn as ``20 log10(|I| / max |I|)``).
    x_m, y_m : (nx,), (ny,) array_like
        Pixel centres (m).
    title : str
        Title; one line per line of text.
    dynamic_range_db : float
        Displayed range below the peak (dB).
    dpi : int
        The resolution the figure is laid out for (PNG pixels per inch).
    min_side_px : int
        Least length of the image's longer side on the PNG (pixels).
    look_direction : (2,) array_like, optional
        Ground direction from the radar towards the scene: drawn as an arrow
        (:func:`draw_look_arrow`).
    """
    v = np.asarray(values)
    ny, nx = v.shape
    k = max(1, int(np.ceil(min_side_px / max(nx, ny))))
    w_in, h_in = k * nx / dpi, k * ny / dpi
    left, right, bottom = 0.9, 1.1, 0.7
    top = 0.25 + 0.22 * (title.count("\n") + 1)
    width = max(left + w_in + right, 6.0)
    height = bottom + h_in + top
    fig = Figure(figsize=(width, height), dpi=dpi)
    x0 = left + 0.5 * (width - left - w_in - right)
    ax = fig.add_axes((x0 / width, bottom / height, w_in / width, h_in / height))
    cax = fig.add_axes(((x0 + w_in + 0.15) / width, bottom / height, 0.18 / width, h_in / height))
    x = np.asarray(x_m)
    y = np.asarray(y_m)
    dx = (x[-1] - x[0]) / max(nx - 1, 1)
    dy = (y[-1] - y[0]) / max(ny - 1, 1)
    im = ax.imshow(
        to_db(v, floor_db=-dynamic_range_db),
        origin="lower",
        extent=(x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2),
        cmap="gray",
        vmin=-dynamic_range_db,
        vmax=0.0,
        interpolation="nearest",
        aspect="auto",
    )
    ax.set_xlabel("x (m)", fontsize=10)
    ax.set_ylabel("y (m)", fontsize=10)
    ax.tick_params(labelsize=9)
    fig.suptitle(title, fontsize=10, y=1.0 - 0.08 / height, va="top")
    fig.colorbar(im, cax=cax, label="dB re peak")
    if look_direction is not None:
        draw_look_arrow(ax, look_direction)
    return fig


def subplots(
    nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], squeeze: bool = True
) -> tuple[Figure, Any]:
    """A new :class:`~matplotlib.figure.Figure` and its axes, without pyplot.

    The figure belongs to no GUI backend and to no global figure list: creating it
    switches nothing for the caller, and it is freed with its last reference.
    """
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, squeeze=squeeze)


def save_figure(fig: Figure, path: str | Path, *, dpi: int = 120, tight: bool = True) -> Path:
    """Save ``fig`` as PNG at ``path``.

    ``tight``: crop to the drawn content (no clipped axis labels); ``False`` keeps the
    figure's own layout (:func:`full_resolution_image_figure`).
    """
    p = Path(path)
    if tight:
        fig.savefig(p, dpi=dpi, bbox_inches="tight", pad_inches=0.1)
    else:
        fig.savefig(p, dpi=dpi)
    return p
