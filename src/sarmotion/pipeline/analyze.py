"""The whole analysis of one acquisition: separate, estimate, separate movers, image.

:func:`analyze` chains the building blocks of the package in the order of the paper
(``sect:algdesc``, ``sect:rotationopt``, ``sect:numeric``):

1. **preliminary image** ``eq:image`` on a square grid around the reference point;
2. **stationary / moving separation** ``M = L + S`` (:func:`sarmotion.separation.separate`);
3. **detection** (:func:`sarmotion.motion.detect_range_speeds`): the peaks of ``g(u)``
   (``eq:OBJg``) on ``S`` are candidates; each is tested by its height over the local
   floor of ``g`` against the threshold of a stated false-alarm rate (set from the
   statistic's measured distribution on data without movers), and by its width;
4. **movers** (:func:`sarmotion.pipeline.estimate_movers`), strongest first, each
   on ``S`` minus the movers already fitted: the maximum-likelihood range position,
   range speed and cross-range speed (:func:`sarmotion.motion.fit_point_mover`: the
   coherent matched filter, searched globally in cross-range speed); a candidate that a
   stationary point with the same range history focuses as well is rejected. All movers
   are then refined jointly, each with the others subtracted, and get their Cramér–Rao
   bound at the measured SNR (:mod:`sarmotion.motion.bounds`) and, beside the fit,
   ``g_perp`` (``eq:OBJ2``). Steps 3 and 4 run on a sub-aperture of about a degree
   (``sub_aperture_deg``): for a wider aperture, on its central degree, and each
   estimate is then moved to the aperture's ``s = 0`` and focused on all pulses
   (:func:`sarmotion.motion.refine_on_aperture`). Each mover also gets its cross-range
   *family* (:func:`sarmotion.motion.family_direction`): the data do not fix where along
   it the mover is. Finally each mover is *separated*: ``T_+^{u, rho}`` at its estimate
   makes its trace vertical at ``t = 0``; its part is the slow-time mean of the aligned
   traces in a fast-time window of ``+- mover_half_window`` samples, mapped back by
   ``T_-^{u, rho}``: the mover's own trace ``D_q``, and ``R <- R - D_q``;
5. **trajectory** of each mover by the phase-space algorithm
   (:func:`sarmotion.motion.estimate_trajectory`) from its own traces;
6. **images**: the stationary image from ``L`` (``M - S``) on the preliminary image's
   pixels (or those within ``stationary_box_m``), and each mover's image
   ``eq:imagecompu`` from its own traces compensated at its estimated velocity;
7. **stationary targets**: bright points of the stationary image.

Steps 1-3 are :func:`sarmotion.pipeline.detect`, step 4 is
:func:`sarmotion.pipeline.estimate_movers` (its named steps, each timed, in
:mod:`sarmotion.pipeline.movers`, with the re-fit of :mod:`sarmotion.pipeline.refit`),
steps 5-7 are in :mod:`sarmotion.pipeline.stages`. Each mover is one
:class:`~sarmotion.pipeline.Mover` record from step 4 on.

The extraction of step 4 was chosen by measurement on Scene 1 (see
:func:`sarmotion.pipeline.movers.extract_mover`): the windowed slow-time mean leaves
less of the mover in the residual than the annihilator ``Q^{u, rho}`` and costs one
transform pair.

Nothing here reads or writes files or prints; progress is reported through a callback
``progress(stage, done, total)``. All positions in m (data frame), speeds in m/s, times
in s.
"""

from __future__ import annotations

from collections.abc import Callable

from numpy.typing import ArrayLike

from ..core.progress import ProgressCallback
from ..core.traces import Traces
from ..imaging import ImageGrid
from ..motion import PointFit
from ._timing import timed
from .detection import detect
from .movers import estimate_movers
from .options import AnalysisOptions
from .results import AnalysisResult
from .stages import estimate_trajectories, mover_images, stationary_image, stationary_targets

__all__ = ["analyze"]


def analyze(
    traces: Traces,
    options: AnalysisOptions | None = None,
    *,
    keep: Callable[[PointFit], bool] | None = None,
    image_outline_m: ArrayLike | None = None,
    stationary_box_m: tuple[float, float, float, float] | None = None,
    progress: ProgressCallback | None = None,
) -> AnalysisResult:
    """Separate, estimate and image the stationary and moving targets of ``traces``.

    See the module docstring for the stages. This is the analysis of one patch's traces,
    the stage below :func:`sarmotion.analyze`
    (:func:`sarmotion.collection.analyze_source`), which plans the patches, runs this on
    each and merges them, and applies the smear rule on every path: a listed stationary
    point on a found mover's echo (within two range cells and two Doppler cells of it at
    some pulse of the analysed aperture) is that mover's smear, dropped and counted in
    ``stationary_mover_images``. Here the listing is the stationary image's, before that
    rule (:func:`sarmotion.collection.drop_smear` applies it to this result).

    Parameters
    ----------
    traces : Traces
        Data ``M``.
    options : AnalysisOptions, optional
        Every choice of the analysis; defaults as documented there.
    keep : callable, optional
        ``keep(fit)``: whether a mover's fit is estimated further
        (:func:`~sarmotion.pipeline.estimate_movers`); default every one.
    image_outline_m : (4, 2) array_like, optional
        A ground parallelogram (m) beyond which the traces hold no stationary echo: the
        preliminary image is formed only within it, 0 beyond
        (:func:`~sarmotion.imaging.backproject`'s ``outline_m``; a collection patch's
        halo, :attr:`sarmotion.collection.Patch.halo_outline_m`). Default: every pixel.
    stationary_box_m : (x0, y0, x1, y1), optional
        The stationary image (and so its listing, whose levels are relative to its
        brightest pixel) is the preliminary image's pixels within this box (m); default
        all of them. A collection's patch lists only its core's targets
        (:func:`sarmotion.collection.analyze_patch`).
    progress : callable, optional
        ``progress(stage, done, total)`` during the long stages.

    Returns
    -------
    AnalysisResult
        Its ``timings_s`` holds each stage's wall-clock time (s) and ``total``, their
        sum; the ``movers.<step>`` entries break ``movers`` down
        (:mod:`sarmotion.pipeline.movers`) and are not added to ``total``.
    """
    detection = detect(traces, options, image_outline_m=image_outline_m, progress=progress)
    opts, acq = detection.options, traces.acquisition
    timings = dict(detection.timings_s)
    with timed(timings, "movers"):
        stage = estimate_movers(detection, keep=keep, progress=progress)
    movers = stage.movers
    with timed(timings, "trajectories"):
        if opts.trajectory:
            movers = estimate_trajectories(movers, acquisition=acq, progress=progress)
    with timed(timings, "images"):
        sep = detection.separation
        stat_img = stationary_image(
            traces,
            sep,
            movers,
            _within(detection.image.grid, stationary_box_m),
            progress=progress,
            device=opts.device,
            method=opts.image_method or "exact",
        )
        movers = mover_images(movers, stat_img, opts, acquisition=acq)
    with timed(timings, "stationary_targets"):
        stationary, sidelobes = stationary_targets(stat_img, sep, opts, acquisition=acq)
    timings["total"] = float(sum(timings.values()))
    timings.update(stage.timings_s)
    return AnalysisResult(
        traces=traces,
        separation=sep,
        range_speeds=detection.candidates.range_speeds,
        detection=detection.candidates,
        movers=movers,
        residual=stage.residual,
        preliminary_image=detection.image,
        stationary_image=stat_img,
        stationary=stationary,
        timings_s=timings,
        options=opts,
        movers_not_estimated=stage.not_estimated,
        stationary_sidelobes=sidelobes,
    )


def _within(grid: ImageGrid, box_m: tuple[float, float, float, float] | None) -> ImageGrid:
    """``grid``'s pixels within ``box_m`` ``(x0, y0, x1, y1)`` (m) (:meth:`ImageGrid.window`)."""
    if box_m is None:
        return grid
    rows, cols = grid.window(box_m)
    return ImageGrid(x_m=grid.x_m[cols], y_m=grid.y_m[rows])
