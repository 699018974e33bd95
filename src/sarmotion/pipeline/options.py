"""The options of the analysis: one frozen, validated object.

Every default is stated with its unit and the principle it comes from. Data-dependent
defaults (the separation method, the RPCA sparsity factor, the scene size) stay ``None``
here and are filled from the traces by :meth:`AnalysisOptions.resolved`, so that the
options written to ``results.json`` are the ones the analysis ran with.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import finite, integer, interval, positive
from ..core.traces import Traces
from ..imaging import default_scene_size_m
from ..separation import SeparationOptions

__all__ = ["AnalysisOptions", "DETECTORS"]

#: The mover detectors (:attr:`AnalysisOptions.detector`).
DETECTORS = ("g", "coherent")


@dataclass(frozen=True, kw_only=True)
class AnalysisOptions:
    """Choices of :func:`~sarmotion.analyze`; every field is keyword-only with a default.

    Attributes
    ----------
    separation : SeparationOptions
        Stationary/moving separation (method, candidate threshold, RPCA parameters);
        see :class:`~sarmotion.separation.SeparationOptions`.
    max_movers : int
        Most movers sought (>= 0). Default 5.
    image_size_m : float or None
        Side of the square preliminary and stationary images around the reference point
        (m); ``None``: :func:`~sarmotion.imaging.default_scene_size_m` (the unambiguous
        ground-range window of the data, at most 100 m).
    spacing_m : float
        Pixel spacing of every image (m). Default 0.25 m, about a fifth of a GOTCHA
        resolution cell.
    mover_image_size_m : float
        Side of each mover's image around its estimated location (m). Default 20 m.
    speed_range_mps : (float, float)
        Range and cross-range speeds searched (m/s). Default (-30, 30), road traffic.
    false_alarm_rate : float
        Per-scene false-alarm rate of the mover detector, in (0, 1). Default 0.01: the
        threshold on the ``g(u)`` peak over its local floor is set from the statistic's
        null distribution on data without movers (:mod:`sarmotion.motion.detector`).
    threshold_db : float or None
        Threshold on that statistic (dB), overriding ``false_alarm_rate``; ``None``
        (default) derives it from the rate.
    detector : {"g", "coherent"}
        The mover detector. ``"g"`` (default): the ``g(u)`` peak over its local floor
        against the threshold of ``false_alarm_rate``. ``"coherent"``: two stages
        (:mod:`sarmotion.motion.coherent`), the ``g(u)`` peaks that reach its null's
        per-candidate 10 % point (or ``threshold_db``) are fitted and each fit's
        generalized likelihood ratio ``|I|^2 / sigma_I^2`` is tested against the
        threshold of ``false_alarm_rate`` from that statistic's measured null.
    stationary_speed_mps : float or None
        Slowest ``g(u)`` peak tested (m/s): slower ones are taken for stationary residue
        (:func:`~sarmotion.pipeline.find_range_speeds`). ``None`` (default): the range
        speed relative to the reference point of a stationary point at the image's
        half-diagonal, ``V (image_size_m / sqrt 2) / R``, and at least two range-speed
        resolutions. A caller that knows the range speeds of its image's stationary
        points gives their largest (a collection's patch,
        :func:`~sarmotion.collection.run.core_stationary_speed`).
    max_peak_width : float
        Widest ``g(u)`` peak accepted as a mover, at half height above the local floor,
        in widths of a noise-free point mover's peak
        (:func:`~sarmotion.motion.point_peak_width`: 2.1 range-speed resolutions for
        GOTCHA). Default 2.5: two movers within 3 resolutions merge into one peak up to
        2.5 such widths, a single mover's is narrower and the residue of stationary
        clutter wider (``docs/notes/detector.md``).
    min_focus_gain_db : float
        Least gain of a mover's matched filter over the best stationary point with the
        same range history, when that point lies within the alias-free cross-range
        extent (dB). Default 1 dB: a stationary target's gain is 0 up to the search
        tolerance, well under 1 dB (``docs/notes/detector.md``).
    defocus_search : bool
        Whether movers are also sought in the stationary band ``g(u)`` leaves untested,
        by their focus over a bank of cross-range speeds (:mod:`sarmotion.pipeline.defocused`):
        a mover whose image lands inside the scene, which the separation takes for
        stationary. Default ``True``: on data without movers its tests explain every
        candidate of three seeds' null scenes
        (``benchmarks/results/detector_null_defocus.md``), and on the movers' benchmark
        it finds the same movers as without it (``movers_accuracy_defocus.md``).
    wide_defocus_search : bool
        Whether the defocus search also looks over twice the central sub-aperture, under
        its bank's first step, where the data hold the pulses (the wide search,
        :mod:`sarmotion.pipeline.defocused`): movers slower across the line of sight than
        a degree can tell from a stationary point. Default ``False``: on the real
        GOTCHA degrees cut into 30 m patches it declared movers at 0.3-0.8 m/s across
        the line of sight where none is known (the bright targets of a real scene are
        not points over two degrees), while on simulated point scenes it finds the
        movers a degree misses (``benchmarks/results/square_km.md``).
    joint_rounds : int
        Rounds of joint maximum-likelihood refinement of all movers, each with the
        others' fitted traces subtracted (>= 0). Default 2.
    stationary_threshold_db : float
        Stationary targets listed down to this level re the brightest pixel of the
        stationary image (dB, <= 0). Default -20 dB.
    max_stationary : int
        Most stationary targets listed (>= 0). Default 100.
    mover_half_window : int or None
        Half-width of a mover's extraction window (fast-time samples); ``None``: three
        compressed-pulse lengths.
    trajectory : bool
        Estimate each mover's trajectory by the phase-space algorithm. Default True.
    sub_aperture_deg : float
        Azimuth span of the sub-aperture the movers are estimated on (degrees, > 0). A
        wider aperture is analysed on its central sub-aperture and each mover is then
        focused on all pulses. Default 1 degree, over which the motion estimates assume
        uniform motion and a straight look.
    device : {"cpu", "cuda"}
        Where the images (preliminary, stationary, each mover's) are backprojected:
        ``"cuda"`` on an NVIDIA GPU (``backproject(device="cuda")``, the ``sarmotion[gpu]``
        extra), the same sum to its own accuracy. Default ``"cpu"``.
    image_method : {"exact", "ffbp"} or None
        How the scene images (preliminary and stationary) are backprojected
        (:func:`~sarmotion.imaging.backproject`'s ``method``): ``"exact"`` the sum over
        every pulse at every pixel; ``"ffbp"`` fast factorised backprojection where its
        cost model predicts a gain (else exact), to its error budget
        (:mod:`sarmotion.imaging.ffbp`). ``None`` (default): exact for one analysis,
        ``"ffbp"`` for the patches of a collection on the CPU, whose halo images are
        large (:func:`~sarmotion.collection.run.analyze_patch`). A mover's own image is
        always exact.
    alias_free_extent_m : float or None
        Cross-range extent (m) about ``alias_free_centre_m`` within which a stationary
        point may explain a candidate (:func:`~sarmotion.motion.stationary_explanation`):
        the extent free of azimuth aliasing of the data the traces hold. ``None``
        (default): the traces' own, ``lambda L / (2 dx)``. A collection's patch, whose
        traces keep one pulse in ``q``, gives the data's (``q`` times its own) about the
        data's reference point: its band holds the echoes of stationary points over that
        extent that the data's pulse rate wraps into it, as the analysis of the whole
        data tests them.
    alias_free_centre_m : (x, y) or None
        Where that extent is centred (m). ``None`` (default): the traces' reference point.

    Notes
    -----
    The detector replaces a fixed 15 dB threshold on ``g(u)`` over its global median,
    which missed movers standing 5-14 dB above it on data nobody tuned for, by a test
    with a stated false-alarm rate (:mod:`sarmotion.motion.detector`).
    """

    separation: SeparationOptions = dataclasses.field(default_factory=SeparationOptions)
    max_movers: int = 5
    image_size_m: float | None = None
    spacing_m: float = 0.25
    mover_image_size_m: float = 20.0
    speed_range_mps: tuple[float, float] = (-30.0, 30.0)
    false_alarm_rate: float = 0.01
    threshold_db: float | None = None
    detector: str = "g"
    stationary_speed_mps: float | None = None
    max_peak_width: float = 2.5
    min_focus_gain_db: float = 1.0
    defocus_search: bool = True
    wide_defocus_search: bool = False
    joint_rounds: int = 2
    stationary_threshold_db: float = -20.0
    max_stationary: int = 100
    mover_half_window: int | None = None
    trajectory: bool = True
    sub_aperture_deg: float = 1.0
    device: str = "cpu"
    image_method: str | None = None
    alias_free_extent_m: float | None = None
    alias_free_centre_m: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.separation, SeparationOptions):
            raise TypeError(
                f"separation must be a SeparationOptions, got {type(self.separation).__name__}"
            )
        integer(self.max_movers, "max_movers", minimum=0)
        if self.image_size_m is not None:
            positive(self.image_size_m, "image_size_m", unit="m")
        positive(self.spacing_m, "spacing_m", unit="m")
        positive(self.mover_image_size_m, "mover_image_size_m", unit="m")
        object.__setattr__(
            self, "speed_range_mps", interval(self.speed_range_mps, "speed_range_mps", unit="m/s")
        )
        rate = finite(self.false_alarm_rate, "false_alarm_rate")
        if not 0.0 < rate < 1.0:
            raise ValueError(f"false_alarm_rate must be in (0, 1), got {self.false_alarm_rate!r}")
        if self.threshold_db is not None:
            finite(self.threshold_db, "threshold_db", unit="dB")
        if self.detector not in DETECTORS:
            raise ValueError(f"detector must be one of {DETECTORS}, got {self.detector!r}")
        if self.stationary_speed_mps is not None:
            positive(self.stationary_speed_mps, "stationary_speed_mps", unit="m/s")
        positive(self.max_peak_width, "max_peak_width")
        finite(self.min_focus_gain_db, "min_focus_gain_db", unit="dB")
        integer(self.joint_rounds, "joint_rounds", minimum=0)
        if finite(self.stationary_threshold_db, "stationary_threshold_db", unit="dB") > 0:
            raise ValueError(
                f"stationary_threshold_db must be <= 0 (dB), got {self.stationary_threshold_db!r}"
            )
        integer(self.max_stationary, "max_stationary", minimum=0)
        if self.mover_half_window is not None:
            integer(self.mover_half_window, "mover_half_window", minimum=1)
        if not isinstance(self.trajectory, bool):
            raise TypeError(f"trajectory must be a bool, got {self.trajectory!r}")
        positive(self.sub_aperture_deg, "sub_aperture_deg", unit="degrees")
        if self.device not in ("cpu", "cuda"):
            raise ValueError(f"device must be 'cpu' or 'cuda', got {self.device!r}")
        if self.alias_free_extent_m is not None:
            positive(self.alias_free_extent_m, "alias_free_extent_m", unit="m")
        if self.alias_free_centre_m is not None:
            c = tuple(float(v) for v in np.asarray(self.alias_free_centre_m, float).ravel())
            if len(c) != 2 or not all(np.isfinite(c)):
                raise ValueError(
                    "alias_free_centre_m must be a finite (x, y) (m), "
                    f"got {self.alias_free_centre_m!r}"
                )
            object.__setattr__(self, "alias_free_centre_m", c)
        if self.image_method not in (None, "exact", "ffbp"):
            raise ValueError(
                f"image_method must be 'exact', 'ffbp' or None, got {self.image_method!r}"
            )

    @property
    def method(self) -> str | None:
        """The separation method (``None`` until :meth:`resolved`)."""
        return self.separation.method

    def resolved(self, traces: Traces) -> AnalysisOptions:
        """These options with every data-dependent default filled from ``traces``."""
        size = self.image_size_m or default_scene_size_m(traces)
        if size / self.spacing_m > 4096:
            raise ValueError(
                f"image_size_m / spacing_m must give <= 4096 pixels a side, "
                f"got {size} m / {self.spacing_m} m"
            )
        return dataclasses.replace(
            self, separation=self.separation.resolved(traces), image_size_m=size
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict of every option (the separation's flattened in)."""
        d = dataclasses.asdict(self)
        sep = d.pop("separation")
        d["speed_range_mps"] = list(self.speed_range_mps)
        if self.stationary_speed_mps is None:  # the image's rule: recorded as before
            del d["stationary_speed_mps"]
        if self.alias_free_extent_m is None:  # the traces' own: recorded as before
            del d["alias_free_extent_m"]
        if not self.wide_defocus_search:  # the default: recorded as before
            del d["wide_defocus_search"]
        if self.alias_free_centre_m is None:
            del d["alias_free_centre_m"]
        else:
            d["alias_free_centre_m"] = list(self.alias_free_centre_m)
        return {**sep, **d}
