"""The ``sarmotion.results/3`` document: an analysis of any size as JSON-ready data.

One document for every analysis: a scene that fits one patch is a collection of one
patch, and :func:`results_document` (one analysis, :func:`sarmotion.pipeline.analyze`)
and :func:`collection_document` (patches, merged) write the same
keys. Every key, with its unit, frame and reference, is described by the JSON Schema
shipped in the package (``sarmotion/documents/schemas/results.json``,
:func:`sarmotion.documents.schema.load_schema`); ``docs/results.md`` explains the frame
and the migration from ``sarmotion.results/2`` and ``sarmotion.collection/1``.

Top-level keys: ``$schema`` (the schema's ``$id``), ``schema``, ``method``,
``reference_point_m``, ``platform_speed_mps``, ``n_pulses``, ``n_samples``,
``aperture_s``, ``aperture_deg``, ``range_speed_resolution_mps``, ``frame`` (the look
direction and the unit vectors the range and cross-range coordinates and speeds are
measured along), ``scene_extent_m``, ``region_m`` and ``plan`` (the analysed region and
its patches), ``detection`` (one patch: the test, the measured null tail, every
candidate; several: null, each patch's in ``patch_summaries``), ``movers``,
``movers_not_estimated``, ``stationary``, ``stationary_dropped``,
``stationary_sidelobes_dropped``, ``stationary_mover_images_dropped`` (listings on a
found mover's smeared echo), ``patch_summaries``, ``timings_s``, ``options``
(``analysis``: the analysis options; the patches' options beside it), ``source``; for
simulated inputs also ``truth``, per-mover ``errors``, ``false_movers`` and
``missed_movers`` (:mod:`sarmotion.pipeline.truth`).

Per mover: what the data fix and what they do not. ``range_m`` and ``range_std_m`` (the
ground-range coordinate from its patch's centre and its Cramér–Rao standard error) are
measured; ``cross_range_known`` is false (a few degrees of one antenna do not fix the
cross-range position) and ``position_m`` is one member of ``cross_range_family``, the
one at the patch centre's cross range; ``cross_range_family.in_scene`` lists the
family's members across the analysed scene (positions and velocities) and
``range_speed_span_mps`` their range speeds; ``position_std_m`` is the spread of a
position known only to lie on that part of the family. ``standard_errors`` says what
they are conditional on. Then the velocity, range and cross-range speeds, peak levels,
``detection``, ``snr_db``, ``amplitude``, ``likelihood_lobes``, the range acceleration,
``trajectory``, ``patch`` (the patch whose fit is kept), ``patches`` (every patch that
found it) and ``image`` (its image's file beside the document, or null).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..collection import CollectionResult
from ..collection.plan import _analysed_pulses
from ..core.acquisition import Acquisition
from ..core.blocks import PulseBlocks
from ..core.geometry import Trajectory, cross_range_speed, look_geometry, range_speed
from ..core.traces import Traces
from ..imaging import resolution
from ..motion import NULL_TAIL, TrajectoryEstimate, azimuth_span_deg
from ..pipeline import (
    AnalysisResult,
    Mover,
    NotEstimated,
    TruthComparison,
    compare_with_truth,
    family_segment,
    range_coordinate,
)
from ..pipeline.truth import MATCH_CELLS, TrueMover, family_match
from .schema import stamped

__all__ = [
    "RESULTS_SCHEMA",
    "READABLE_RESULTS_SCHEMAS",
    "STANDARD_ERRORS_CONDITION",
    "collection_document",
    "collection_mover_images",
    "describe_patch",
    "mover_entries",
    "plan_document",
    "results_document",
]

#: Schema name of the results document.
RESULTS_SCHEMA = "sarmotion.results/3"

#: Versions a reader of results.json (the HTML report) accepts.
READABLE_RESULTS_SCHEMAS = ("sarmotion.results/1", "sarmotion.results/2", RESULTS_SCHEMA)

#: What a mover's standard errors are conditional on, in words (``standard_errors``).
STANDARD_ERRORS_CONDITION = (
    "the mover at the listed position's cross range (the member of its cross-range "
    "family at its patch centre's cross range): the data do not fix where along the "
    "family it is, and the spread along it (cross_range_family.range_speed_span_mps, "
    "position_std_m) is not in these errors"
)


def results_document(
    result: AnalysisResult,
    *,
    truth: TruthComparison | None = None,
    plan: Any = None,
    collection_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The ``sarmotion.results/3`` document of one analysis: a collection of one patch.

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    truth : TruthComparison, optional
        Its comparison with the true scene; adds ``truth``, per-mover ``errors``,
        ``false_movers`` and ``missed_movers``.
    plan : PatchPlan, optional
        The plan that made the region one patch (:func:`sarmotion.collection.plan_patches`);
        default the analysis's own image as the region and its one patch.
    collection_options : dict, optional
        The patches' options (``CollectionOptions.to_dict()``), put in ``options`` beside
        ``analysis``.
    """
    tr = result.traces
    g = result.stationary_image.grid
    extent = (float(g.x_m[0]), float(g.x_m[-1]), float(g.y_m[0]), float(g.y_m[-1]))
    movers = mover_entries(result)
    for entry in movers:
        entry["patch"], entry["patches"] = 0, [0]
    plan_doc = plan_document(plan) if plan is not None else _own_plan(result, extent)
    doc: dict[str, Any] = {
        "method": result.method,
        "reference_point_m": [float(v) for v in tr.reference_point_m],
        "platform_speed_mps": float(tr.geometry.speed_mps),
        "n_pulses": int(tr.n_pulses),
        "n_samples": int(tr.n_samples),
        "aperture_s": float(tr.slow_times_s[-1] - tr.slow_times_s[0]),
        "aperture_deg": float(azimuth_span_deg(tr)),
        "range_speed_resolution_mps": float(result.range_speeds.resolution_mps),
        "frame": _frame(tr),
        "scene_extent_m": list(extent),
        "region_m": list(plan_doc["region_m"]),
        "plan": plan_doc,
        "detection": _detection(result),
        "movers": movers,
        "movers_not_estimated": [
            {**_not_estimated(c), "patch": 0} for c in result.movers_not_estimated
        ],
        "stationary": [
            {"position_m": list(s.position_m), "peak_db": float(s.level_db), "patch": 0}
            for s in result.stationary
        ],
        "stationary_dropped": 0,
        "stationary_sidelobes_dropped": int(result.stationary_sidelobes),
        "stationary_mover_images_dropped": int(result.stationary_mover_images),
        "patch_summaries": [
            {
                "index": 0,
                "movers": len(result.movers),
                "movers_not_estimated": len(result.movers_not_estimated),
                "stationary_listed": len(result.stationary),
                "stationary_cap_reached": len(result.stationary) >= result.options.max_stationary,
                "method": result.method,
                "n_pulses": int(tr.n_pulses),
                "n_samples": int(tr.n_samples),
                "timings_s": {k: float(v) for k, v in result.timings_s.items()},
            }
        ],
        "timings_s": {k: float(v) for k, v in result.timings_s.items()},
        "options": {**(collection_options or {}), "analysis": result.options.to_dict()},
        "source": {k: v for k, v in tr.metadata.items() if _jsonable(v)},
    }
    if truth is not None:
        cmp = truth.to_dict()
        doc["truth"] = cmp["truth"]
        for entry, err in zip(doc["movers"], cmp["errors"], strict=True):
            entry["errors"] = err
        doc["false_movers"] = cmp["false_movers"]
        doc["missed_movers"] = cmp["missed_movers"]
    return stamped(RESULTS_SCHEMA, doc)


def collection_document(
    result: CollectionResult,
    source: PulseBlocks | None = None,
    *,
    scene: Any = None,
) -> dict[str, Any]:
    """The ``sarmotion.results/3`` document of a collection (patches, merged).

    The keys of :func:`results_document`; a mover's ``range_m``, family and speeds are
    measured from its kept patch's centre (``plan.patches[patch].centre_m``, that
    patch's reference point), and ``detection`` is null (each patch tested its own
    candidates at the collection's false-alarm rate shared among them,
    :func:`sarmotion.collection.run.patch_false_alarm`). A region of one patch is the
    analysis's own document (:func:`results_document` with the plan).

    Parameters
    ----------
    result : CollectionResult
        The merged analysis (:func:`sarmotion.collection.analyze_collection`).
    source : PulseBlocks, optional
        The data it was made from (their axes); default those the result kept
        (``result.source``, :func:`sarmotion.analyze`).
    scene : Scene, optional
        The simulated scene of the data: adds ``truth``, per-mover ``errors``,
        ``false_movers`` and ``missed_movers`` (the movers matched on their families as
        :func:`sarmotion.pipeline.compare_with_truth` matches them, each in its kept
        patch's geometry).
    """
    copts = result.options.to_dict()
    source = result.source if source is None else source
    if result.single_result is not None:
        single = result.single_result
        truth = compare_with_truth(single, scene) if scene is not None else None
        doc = results_document(single, truth=truth, plan=result.plan, collection_options=copts)
        doc["timings_s"] = {
            **doc["timings_s"],
            **{f"collection.{k}": float(v) for k, v in result.timings_s.items()},
        }
        return doc
    if source is None:
        raise TypeError("collection_document: a result of several patches needs its source")
    acq = Acquisition(
        trajectory=source.trajectory, radar=source.radar, reference_point_m=source.reference_point_m
    )
    sub = _analysed_trajectory(source, result.options.analysis.sub_aperture_deg)
    duration = float(sub.slow_times_s[-1] - sub.slow_times_s[0])
    peak = max([t.level for t in result.stationary], default=0.0)
    plan = plan_document(result.plan)
    movers = []
    for rec, patches in result.movers:
        entry = {k: v for k, v in rec.document.items() if not k.startswith("_")}
        entry["patch"] = int(rec.patch)
        entry["patches"] = [int(p) for p in patches]
        movers.append(entry)
    methods = sorted({r.method for r in result.patches})
    x0, x1, y0, y1 = (float(v) for v in result.mosaic_extent_m)
    doc: dict[str, Any] = {
        "method": methods[0] if len(methods) == 1 else ", ".join(methods),
        "reference_point_m": [float(v) for v in source.reference_point_m],
        "platform_speed_mps": float(acq.geometry.speed_mps),
        "n_pulses": int(source.n_pulses),
        "n_samples": int(source.radar.n_samples),
        "aperture_s": float(acq.slow_times_s[-1] - acq.slow_times_s[0]),
        "aperture_deg": float(azimuth_span_deg(acq)),
        # range resolution over half the analysed sub-aperture's duration (eq:OBJg)
        "range_speed_resolution_mps": float(
            source.radar.range_resolution_m / (0.5 * duration) if duration > 0 else np.inf
        ),
        "frame": _frame(acq),
        "scene_extent_m": [x0, x1, y0, y1],
        "region_m": list(plan["region_m"]),
        "plan": plan,
        "detection": None,
        "movers": movers,
        "movers_not_estimated": [
            {**_not_estimated(c), "patch": int(r.index)}
            for r in result.patches
            for c in r.not_estimated
        ],
        "stationary": [
            {
                "position_m": [float(v) for v in t.position_m],
                "peak_db": float(20 * np.log10(max(t.level, 1e-300) / peak)) if peak > 0 else 0.0,
                "patch": int(t.patch),
            }
            for t in result.stationary
        ],
        "stationary_dropped": int(result.stationary_dropped),
        "stationary_sidelobes_dropped": int(result.stationary_sidelobes),
        "stationary_mover_images_dropped": int(result.stationary_mover_images),
        "patch_summaries": [
            {
                "index": int(r.index),
                "movers": len(r.movers),
                "movers_not_estimated": len(r.not_estimated),
                "stationary_listed": int(r.listed),
                "stationary_cap_reached": bool(r.capped),
                "method": r.method,
                "n_pulses": int(r.n_pulses),
                "n_samples": int(r.n_samples),
                "timings_s": {k: float(v) for k, v in r.timings_s.items()},
            }
            for r in result.patches
        ],
        "timings_s": {k: float(v) for k, v in result.timings_s.items()},
        "options": {**copts, "analysis": result.options.analysis.to_dict()},
        "source": {k: v for k, v in source.metadata.items() if _jsonable(v)},
    }
    if scene is not None:
        _collection_truth(doc, scene, source)
    return stamped(RESULTS_SCHEMA, doc)


def collection_mover_images(result: CollectionResult) -> list[dict[str, Any] | None]:
    """Each merged mover's image as its kept patch made it (``{"x_m", "y_m", "magnitude"}``).

    ``None`` for a mover whose patch kept no image (:func:`describe_patch`).
    """
    if result.single_result is not None:
        return [
            None if m.image is None else _image_record(m.image) for m in result.single_result.movers
        ]
    return [rec.document.get("_image") for rec, _ in result.movers]


def describe_patch(result: AnalysisResult) -> list[dict[str, Any]]:
    """A patch's mover entries with each mover's image (``_image``, not written).

    The ``describe`` of :func:`sarmotion.collection.analyze_collection`: the entry of the
    document and, under ``_image``, the magnitude of the mover's compensated image on its
    grid (float32), which the report draws (:func:`collection_mover_images`).
    """
    entries = mover_entries(result)
    for entry, m in zip(entries, result.movers, strict=True):
        entry["_image"] = None if m.image is None else _image_record(m.image)
    return entries


def _image_record(image: Any) -> dict[str, Any]:
    return {
        "x_m": np.asarray(image.grid.x_m, np.float64),
        "y_m": np.asarray(image.grid.y_m, np.float64),
        "magnitude": np.abs(image.values).astype(np.float32),
    }


def _analysed_trajectory(source: PulseBlocks, sub_aperture_deg: float) -> Trajectory:
    """The central pulses the movers were estimated on (the patches' rule)."""
    sl = _analysed_pulses(source, sub_aperture_deg)
    traj = source.trajectory
    return Trajectory(positions_m=traj.positions_m[sl], slow_times_s=traj.slow_times_s[sl])


def _collection_truth(doc: dict[str, Any], scene: Any, source: PulseBlocks) -> None:
    """``truth``, per-mover ``errors``, ``false_movers``, ``missed_movers`` of a collection.

    Each estimate is matched on its cross-range family slid to a true mover
    (:func:`sarmotion.pipeline.compare_with_truth`'s rule,
    :func:`sarmotion.pipeline.truth.family_match`), the true range speed and the
    resolutions taken in the geometry of the estimate's kept patch (its centre is that
    patch's reference point). Errors are estimate minus truth, as
    :class:`sarmotion.pipeline.MoverErrors` (``family_*``: the member of the estimate's
    family at the truth's cross-range offset; no trajectory error).
    """
    traj = source.trajectory
    z = float(source.reference_point_m[2])
    tol = MATCH_CELLS * doc["range_speed_resolution_mps"]
    # half the analysed sub-aperture's duration, from the range-speed resolution (eq:OBJg)
    half_s = source.radar.range_resolution_m / doc["range_speed_resolution_mps"]
    centres = [np.r_[p["centre_m"][:2], z] for p in doc["plan"]["patches"]]
    geom0 = look_geometry(traj, source.reference_point_m)
    truth = [
        {
            "label": t.label or f"mover {i + 1}",
            "position_m": [float(t.position_m[0]), float(t.position_m[1])],
            "velocity_mps": [float(t.velocity_mps[0]), float(t.velocity_mps[1])],
            "range_speed_mps": float(range_speed(t.velocity_mps, geom0)),
            "cross_range_speed_mps": float(cross_range_speed(t.velocity_mps, geom0)),
        }
        for i, t in enumerate(scene.moving)
    ]
    used: set[int] = set()
    matched = 0
    for entry in doc["movers"]:
        geom = look_geometry(traj, centres[entry["patch"]])
        b = np.asarray(geom.ground_m_o, float)[:2]
        e_r = b / np.linalg.norm(b)
        e_c = np.array([-e_r[1], e_r[0]])
        u = entry["range_speed_mps"]
        cands = []
        for i, t in enumerate(truth):
            cost = None
            if i not in used:
                cost = family_match(
                    position_m=entry["position_m"],
                    velocity_mps=entry["velocity_mps"],
                    range_speed_mps=u,
                    position_per_m=entry["cross_range_family"]["position_per_m"],
                    velocity_per_m=entry["cross_range_family"]["velocity_mps_per_m"],
                    truth=TrueMover(
                        label=t["label"],
                        position_m=tuple(t["position_m"]),
                        velocity_mps=tuple(t["velocity_mps"]),
                        range_speed_mps=float(range_speed(t["velocity_mps"], geom)),
                        cross_range_speed_mps=float(cross_range_speed(t["velocity_mps"], geom)),
                    ),
                    cross_range_direction=e_c,
                    scales=(
                        source.radar.range_resolution_m / float(np.linalg.norm(b)),
                        tol / MATCH_CELLS,
                        source.radar.wavelength_m
                        * float(np.linalg.norm(traj.centre_m - centres[entry["patch"]]))
                        / (8.0 * doc["platform_speed_mps"] * half_s**2),
                    ),
                )
            if cost is not None:
                cands.append((cost, i))
        if not cands:
            entry["errors"] = None
            continue
        i = min(cands)[1]
        used.add(i)
        matched += 1
        t = truth[i]
        tv = np.asarray(t["velocity_mps"], float)
        dp = np.asarray(entry["position_m"], float) - np.asarray(t["position_m"], float)
        di = np.asarray(entry["image_peak_m"], float) - np.asarray(t["position_m"], float)
        a = np.asarray(entry["cross_range_family"]["position_per_m"], float)
        bv = np.asarray(entry["cross_range_family"]["velocity_mps_per_m"], float)
        ac = float(a @ e_c)
        offset = -float(dp @ e_c) / ac if abs(ac) > 1e-12 else 0.0
        fp = dp + offset * a
        v = np.asarray(entry["velocity_mps"], float)
        fv = v + offset * bv - tv
        entry["errors"] = {
            "matched": t["label"],
            "position_m": float(np.hypot(*dp)),
            "position_range_m": float(dp @ e_r),
            "position_cross_range_m": float(dp @ e_c),
            "image_peak_m": float(np.hypot(*di)),
            "image_peak_range_m": float(di @ e_r),
            "image_peak_cross_range_m": float(di @ e_c),
            "velocity_mps": float(np.hypot(*(v - tv))),
            "range_speed_mps": float(u - range_speed(tv, geom)),
            "cross_range_speed_mps": float(
                entry["cross_range_speed_mps"] - cross_range_speed(tv, geom)
            ),
            "family_offset_m": offset,
            "family_position_m": float(np.hypot(*fp)),
            "family_velocity_mps": float(np.hypot(*fv)),
            "trajectory_max_m": None,
            "trajectory_rms_m": None,
        }
    doc["truth"] = truth
    doc["false_movers"] = sum(e.get("errors") is None for e in doc["movers"])
    doc["missed_movers"] = len(truth) - matched


def mover_entries(result: AnalysisResult) -> list[dict[str, Any]]:
    """The ``movers`` entries of an analysis, without ``patch``, ``patches`` and ``errors``.

    ``image`` is null: the writer of the files beside the document names them.
    """
    g = result.stationary_image.grid
    extent = (float(g.x_m[0]), float(g.x_m[-1]), float(g.y_m[0]), float(g.y_m[-1]))
    return [_mover(m, result.traces, extent) for m in result.movers]


def plan_document(plan: Any) -> dict[str, Any]:
    """The ``plan`` of the document: ``PatchPlan.to_dict()`` and what else the plan states.

    ``region``, ``unambiguous_scene`` and ``outside`` (the declared region, the data's
    unambiguous scene and what of the region falls outside it) are written when the plan
    has them, as JSON-ready values (null otherwise).
    """
    out = dict(plan.to_dict())
    for key in ("region", "unambiguous_scene", "outside"):
        out[key] = _plain(getattr(plan, key, None))
    return out


def _own_plan(result: AnalysisResult, extent: tuple[float, float, float, float]) -> dict:
    """One patch, the analysis's image: the plan of an analysis made without a plan."""
    tr = result.traces
    x0, x1, y0, y1 = extent
    prf = 1.0 / float(tr.trajectory.pulse_interval_s) if tr.n_pulses > 1 else 0.0
    region = [x0, y0, x1, y1]
    return {
        "region_m": region,
        "patch_size_m": float(max(x1 - x0, y1 - y0)),
        "unambiguous_scene_m": None,
        "range_margin_m": None,
        "doppler_margin_hz": None,
        "patches": [
            {
                "index": 0,
                "core_m": region,
                "centre_m": [float(v) for v in tr.reference_point_m[:2]],
                "n_pulses": int(tr.n_pulses),
                "n_samples": int(tr.n_samples),
                "decimation": 1,
                "passband_hz": 0.5 * prf,
                "n_taps": 1,
            }
        ],
        "region": None,
        "unambiguous_scene": None,
        "outside": None,
    }


def _plain(value: Any) -> Any:
    """``value`` as JSON-ready data: arrays as lists, objects by their ``to_dict``."""
    if value is None or isinstance(value, str | bool | int | float):
        return value
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    if hasattr(value, "to_dict"):
        return _plain(value.to_dict())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _plain(dataclasses.asdict(value))
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return str(value)


def _frame(tr: Traces | Acquisition) -> dict[str, Any]:
    """The look direction and the ground unit vectors of range and cross range (module notes)."""
    geom = tr.geometry
    cells = resolution(tr)
    m_o, t = np.asarray(geom.m_o, float), np.asarray(geom.tangent, float)
    return {
        "look_direction": m_o.tolist(),
        "flight_tangent": t.tolist(),
        "range_direction": [float(v) for v in cells.range_direction],
        "cross_range_direction": [float(v) for v in cells.cross_range_direction],
        "range_speed_vector": m_o[:2].tolist(),
        "cross_range_speed_vector": (geom.projector @ t)[:2].tolist(),
    }


def _mover(m: Mover, tr: Traces, extent: tuple[float, float, float, float]) -> dict[str, Any]:
    seg = family_segment(tr, m.position_m, m.velocity_mps, m.family_position_per_m, extent)
    in_scene = (
        None
        if seg is None
        else {
            "cross_offsets_m": seg.cross_offsets_m.tolist(),
            "positions_m": seg.positions_m.tolist(),
            "velocities_mps": seg.velocities_mps.tolist(),
            "range_history_rms_m": seg.rms_m.tolist(),
        }
    )
    span = None
    if seg is not None:  # range speed u . m_o of each member across the scene
        rates = seg.velocities_mps @ np.asarray(tr.geometry.m_o, float)[:2]
        span = [float(rates.min()), float(rates.max())]
    entry: dict[str, Any] = {
        "position_m": [float(v) for v in m.position_m[:2]],
        "position_std_m": None if seg is None else _along_std(seg.positions_m),
        "cross_range_known": False,
        "range_m": range_coordinate(tr, m.position_m),
        "range_std_m": float(m.bound.range_position_m),
        "velocity_mps": [float(v) for v in m.velocity_mps],
        "range_speed_mps": float(m.range_speed_mps),
        "cross_range_speed_mps": float(m.cross_range_speed_mps),
        "peak_db": float(m.image_peak_db),
        "g_peak_db": float(m.evidence.statistic_db),
        "image_peak_m": [float(v) for v in m.image_peak_m],
        "cross_range_family": {
            "position_per_m": [float(v) for v in m.family_position_per_m],
            "velocity_mps_per_m": [float(v) for v in m.family_velocity_per_m],
            "in_scene": in_scene,
            "range_speed_span_mps": span,
        },
        "image": None,
    }
    ev, b = m.evidence, m.bound
    entry["detection"] = {
        "statistic_db": float(ev.statistic_db),
        "threshold_db": float(ev.threshold_db),
        "false_alarm_rate": float(ev.false_alarm_rate),
        "p_value": float(ev.p_value),
        "width_resolutions": float(ev.width_resolutions),
        "focus_gain_db": float(ev.focus_gain_db),
        "stationary_point_m": [float(v) for v in ev.stationary_point_m],
        "stationary_within_extent": bool(ev.stationary_within_extent),
    }
    if ev.coherent_statistic_db is not None:  # the coherent detector's stage 2
        entry["detection"]["coherent"] = {
            "statistic_db": float(ev.coherent_statistic_db),
            "threshold_db": float(ev.coherent_threshold_db),
            "p_value": float(ev.coherent_p_value),
        }
    if ev.defocus is not None:  # found in the stationary band by its focus
        d = ev.defocus
        entry["detection"]["defocus"] = {
            "statistic_db": float(d.statistic_db),
            "threshold_db": float(d.threshold_db),
            "p_value": float(d.p_value),
            "smear_margin_db": float(d.smear_margin_db),
            "bank_cross_range_speed_mps": float(d.bank_cross_range_speed_mps),
        }
    entry["standard_errors"] = {
        "range_position_m": b.range_position_m,
        "range_speed_mps": b.range_speed_mps,
        "cross_range_speed_mps": b.cross_range_speed_mps,
        "amplitude": b.amplitude,
        "kind": "Cramér–Rao bound at the measured SNR, cross-range coordinate held",
        "conditional_on": STANDARD_ERRORS_CONDITION,
    }
    entry["snr_db"] = b.snr_db
    entry["amplitude"] = [float(m.fit.amplitude.real), float(m.fit.amplitude.imag)]
    entry["amplitude_complex"] = {"re": entry["amplitude"][0], "im": entry["amplitude"][1]}
    entry["g_perp_cross_range_speed_mps"] = float(m.g_perp.speed_mps)
    lobes = m.separated_fit  # the global search over cross-range speed ran on S
    entry["likelihood_lobes"] = {
        "ambiguous": bool(lobes.ambiguous),
        "lobe_ratio": float(lobes.lobe_ratio),
        "other_cross_range_speed_mps": (
            None
            if lobes.other_cross_range_speed_mps is None
            else float(lobes.other_cross_range_speed_mps)
        ),
    }
    acc = m.acceleration  # None on one sub-aperture: not separable from u_p there
    entry["range_acceleration_mps2"] = (
        float(acc.range_acceleration_mps2) if acc is not None and acc.estimable else None
    )
    entry["range_acceleration_std_mps2"] = None if acc is None else float(acc.std_mps2)
    entry["range_acceleration_estimable"] = bool(acc is not None and acc.estimable)
    if m.trajectory is not None:
        knots = m.trajectory.knot_times_s
        times = np.r_[knots[:, 0], knots[-1, 1]]
        entry["trajectory"] = {
            "slow_times_s": times.tolist(),
            "velocities_mps": m.trajectory.velocities_mps.tolist(),
            "positions_m": _knot_positions(m.trajectory, times).tolist(),
        }
    return entry


def _along_std(positions_m: np.ndarray) -> float:
    """Standard deviation (m) of a point uniform along the polyline ``positions_m``.

    What a position known only to lie on the family's part in the scene is known to: its
    second moment about the polyline's centroid, segment by segment (a straight family
    of length ``L`` gives ``L / sqrt 12``).
    """
    p = np.asarray(positions_m, dtype=np.float64)
    a, b = p[:-1], p[1:]
    lengths = np.linalg.norm(b - a, axis=1)
    total = float(lengths.sum())
    if total <= 0.0:
        return 0.0
    mid = 0.5 * (a + b)
    centre = (lengths[:, None] * mid).sum(axis=0) / total
    # E|x - c|^2 on a segment: |mid - c|^2 + |b - a|^2 / 12
    second = lengths * (np.sum((mid - centre) ** 2, axis=1) + lengths**2 / 12.0)
    return float(np.sqrt(second.sum() / total))


def _knot_positions(tj: TrajectoryEstimate, times: np.ndarray) -> np.ndarray:
    """Ground positions (m) of the piecewise-linear trajectory at ``times`` (s), shape (n, 2).

    ``rho(t) = rho(0) + integral_0^t u(s) ds`` with ``u`` the velocity of each straight
    segment ``[knot_k, knot_k+1]`` (the estimate's definition).
    """
    a, b = tj.knot_times_s[:, 0], tj.knot_times_s[:, 1]
    t = np.asarray(times, dtype=np.float64)[:, None]
    # signed length of each segment's overlap with [0, t] (negative for t < 0)
    forward = np.clip(np.minimum(b, t) - np.maximum(a, 0.0), 0.0, None)
    backward = np.clip(np.minimum(b, 0.0) - np.maximum(a, t), 0.0, None)
    lengths = np.where(t >= 0.0, forward, -backward)
    return tj.position_at_zero_m[:2][None, :] + lengths @ tj.velocities_mps


def _not_estimated(c: NotEstimated) -> dict[str, Any]:
    return {
        "range_speed_mps": float(c.range_speed_mps),
        "statistic_db": float(c.statistic_db),
        "width_resolutions": float(c.width_resolutions),
        "range_m": float(c.range_m),
    }


def _detection(result: AnalysisResult) -> dict[str, Any] | None:
    """The detector's test and every ``g(u)`` candidate (:mod:`sarmotion.motion.detector`)."""
    d = result.detection
    if d is None:
        return None
    st = d.statistics
    return {
        "statistic": "g(u) peak over the median of g at 2-12 range-speed resolutions (dB)",
        "threshold_db": float(d.threshold_db),
        "false_alarm_rate": float(d.false_alarm_rate),
        "n_candidates": d.n_candidates,
        "null_tail": dict(NULL_TAIL),
        "min_speed_mps": float(d.min_speed_mps),
        "max_width_resolutions": float(d.max_width),
        "min_focus_gain_db": float(result.options.min_focus_gain_db),
        "candidates": [
            {"range_speed_mps": float(u), "statistic_db": float(t), "width_resolutions": float(w)}
            for u, t, w in zip(st.speeds_mps, st.statistic_db, st.width_resolutions, strict=True)
            if t >= d.threshold_db - 3.0
        ],
    }


def _jsonable(v: Any) -> bool:
    return isinstance(v, str | int | float | bool) or (
        isinstance(v, list | tuple) and all(isinstance(x, str | int | float | bool) for x in v)
    )
