"""One entry point for the three separation methods, with one set of defaults.

:func:`separate` serves the analysis pipeline and the ``separate`` command alike:
``combined`` and ``annihilation`` take their stationary candidates from a preliminary
image, ``rpca`` needs none. :class:`SeparationOptions` holds every choice, each default
stated with its unit; data-dependent defaults (the method, the RPCA sparsity factor) are
filled by :meth:`SeparationOptions.resolved` from the traces.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .._validation import finite, integer, one_of, positive
from ..core import ProgressCallback, Traces
from ..imaging import Image
from .annihilation import separate_annihilation
from .candidates import stationary_candidates
from .combined import separate_combined
from .result import Separation
from .rpca_separation import separate_rpca

__all__ = ["METHODS", "SeparationOptions", "default_method", "separate"]

#: The separation methods, in order of preference for point scenes.
METHODS = ("combined", "rpca", "annihilation")


def default_method(traces: Traces) -> str:
    """Separation method for ``traces``: the one suited to its kind of clutter.

    ``"combined"`` for simulated point scenes, ``"rpca"`` for measured data.

    Notes
    -----
    ``combined`` models the stationary scene as a set of points, which a simulated scene
    is; measured clutter is distributed, not a set of points, and robust PCA leaves the
    movers' ``g`` peaks far higher above the floor there, in a fraction of the time
    (figures in ``docs/notes/separation.md``, from ``tests/separation/test_separation.py`` and
    ``tests/separation/test_separation_gotcha.py``).
    """
    return "combined" if traces.metadata.get("source") == "simulation" else "rpca"


@dataclass(frozen=True, kw_only=True)
class SeparationOptions:
    """Choices of the stationary/moving separation.

    Attributes
    ----------
    method : {"combined", "rpca", "annihilation"} or None
        Separation method; ``None``: :func:`default_method`.
    candidate_threshold_db : float
        ``combined``, ``annihilation``: stationary candidates are the bright points of
        the preliminary image within this level of its peak (dB, <= 0). Default -20 dB.
    eta_scale : float or None
        ``rpca``: factor on the default sparsity weight ``1 / sqrt(max(n, window))``;
        ``None``: 1 for simulations, 2 for measured (distributed) clutter.
    rpca_window : int or None
        ``rpca``: fast-time window (samples); ``None`` chooses it from the data.
    rpca_tol : float
        ``rpca``: stopping rule ``||M - L - S||_F <= tol ||M||_F`` per window. Default
        1e-4 (the same movers as 1e-6 on GOTCHA: g peaks 23.6/21.9 dB against 23.7/21.9).
    """

    method: str | None = None
    candidate_threshold_db: float = -20.0
    eta_scale: float | None = None
    rpca_window: int | None = None
    rpca_tol: float = 1e-4

    def __post_init__(self) -> None:
        if self.method is not None:
            one_of(self.method, "method", METHODS)
        if finite(self.candidate_threshold_db, "candidate_threshold_db", unit="dB") > 0:
            raise ValueError(
                f"candidate_threshold_db must be <= 0 (dB re the peak), "
                f"got {self.candidate_threshold_db!r}"
            )
        if self.eta_scale is not None:
            positive(self.eta_scale, "eta_scale")
        if self.rpca_window is not None:
            integer(self.rpca_window, "rpca_window", minimum=2)
        positive(self.rpca_tol, "rpca_tol")

    def resolved(self, traces: Traces) -> SeparationOptions:
        """These options with ``method`` and ``eta_scale`` filled from ``traces``."""
        simulated = traces.metadata.get("source") == "simulation"
        return dataclasses.replace(
            self,
            method=self.method or default_method(traces),
            eta_scale=self.eta_scale or (1.0 if simulated else 2.0),
        )


def separate(
    traces: Traces,
    image: Image | None = None,
    options: SeparationOptions | None = None,
    *,
    progress: ProgressCallback | None = None,
) -> Separation:
    """Separate the traces of stationary and moving targets: ``M = L + S``.

    Parameters
    ----------
    traces : Traces
        Data ``M``.
    image : Image, optional
        Preliminary (stationary) image of ``traces``; required by ``combined`` and
        ``annihilation``, which read their stationary candidates from it.
    options : SeparationOptions, optional
        Method and parameters; defaults as documented there.
    progress : callable, optional
        ``progress(stage, done, total)``.

    Returns
    -------
    Separation
    """
    opts = (options or SeparationOptions()).resolved(traces)
    if opts.method == "rpca":
        return separate_rpca(
            traces,
            window=opts.rpca_window,
            eta_scale=opts.eta_scale,
            tol=opts.rpca_tol,
            progress=progress,
        )
    if image is None:
        raise ValueError(f"the {opts.method} separation needs a preliminary image")
    grid = image.grid
    if opts.method == "combined":
        return separate_combined(
            traces,
            image_values=image.values,
            x_m=grid.x_m,
            y_m=grid.y_m,
            threshold_db=opts.candidate_threshold_db,
            progress=progress,
        )
    points = stationary_candidates(
        image.values,
        x_m=grid.x_m,
        y_m=grid.y_m,
        traces=traces,
        threshold_db=opts.candidate_threshold_db,
    )
    return separate_annihilation(traces, points)
