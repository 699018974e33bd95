"""The ``sarmotion.results/1`` document: an analysis as JSON-ready data.

Top-level keys: ``schema``, ``method``, ``reference_point_m``, ``platform_speed_mps``,
``n_pulses``, ``n_samples``, ``aperture_s``, ``aperture_deg``,
``range_speed_resolution_mps``, ``movers`` (position_m, velocity_mps, range and
cross-range speeds, peak levels, ``cross_range_family``, ``trajectory``), ``stationary``,
``timings_s``, ``options``, ``source``; for simulated inputs also ``truth``, per-mover
``errors``, ``false_movers`` and ``missed_movers`` (:mod:`sarmotion.pipeline.truth`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..motion import azimuth_span_deg
from ..pipeline import AnalysisResult, MoverResult, TruthComparison

__all__ = ["RESULTS_SCHEMA", "results_document", "write_json"]

#: Schema name of the results document.
RESULTS_SCHEMA = "sarmotion.results/1"


def results_document(
    result: AnalysisResult, *, truth: TruthComparison | None = None
) -> dict[str, Any]:
    """The ``sarmotion.results/1`` document of ``result`` (lists, floats, strings).

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    truth : TruthComparison, optional
        Its comparison with the true scene; adds ``truth``, per-mover ``errors``,
        ``false_movers`` and ``missed_movers``.
    """
    tr = result.traces
    doc: dict[str, Any] = {
        "schema": RESULTS_SCHEMA,
        "method": result.method,
        "reference_point_m": [float(v) for v in tr.reference_point_m],
        "platform_speed_mps": float(tr.geometry.speed_mps),
        "n_pulses": int(tr.n_pulses),
        "n_samples": int(tr.n_samples),
        "aperture_s": float(tr.slow_times_s[-1] - tr.slow_times_s[0]),
        "aperture_deg": float(azimuth_span_deg(tr)),
        "range_speed_resolution_mps": float(result.range_speeds.resolution_mps),
        "movers": [_mover(m) for m in result.movers],
        "stationary": [
            {"position_m": list(s.position_m), "peak_db": float(s.peak_db)}
            for s in result.stationary
        ],
        "timings_s": {k: float(v) for k, v in result.timings_s.items()},
        "options": result.options.to_dict(),
        "source": {k: v for k, v in tr.metadata.items() if _jsonable(v)},
    }
    if truth is not None:
        cmp = truth.to_dict()
        doc["truth"] = cmp["truth"]
        for entry, err in zip(doc["movers"], cmp["errors"], strict=True):
            entry["errors"] = err
        doc["false_movers"] = cmp["false_movers"]
        doc["missed_movers"] = cmp["missed_movers"]
    return doc


def _mover(m: MoverResult) -> dict[str, Any]:
    e = m.estimate
    entry: dict[str, Any] = {
        "position_m": [float(v) for v in e.position_m[:2]],
        "velocity_mps": [float(v) for v in e.velocity_mps],
        "range_speed_mps": float(e.range_speed_mps),
        "cross_range_speed_mps": float(e.cross_range_speed_mps),
        "peak_db": float(m.peak_db),
        "g_peak_db": float(e.peak_db),
        "image_peak_m": [float(v) for v in m.image_peak_m],
        "cross_range_family": {
            "position_per_m": [float(v) for v in m.family_position_per_m],
            "velocity_mps_per_m": [float(v) for v in m.family_velocity_per_m],
        },
    }
    if m.trajectory is not None:
        knots = m.trajectory.knot_times_s
        entry["trajectory"] = {
            "slow_times_s": knots[:, 0].tolist() + [float(knots[-1, 1])],
            "velocities_mps": m.trajectory.velocities_mps.tolist(),
        }
    return entry


def _jsonable(v: Any) -> bool:
    return isinstance(v, str | int | float | bool) or (
        isinstance(v, list | tuple) and all(isinstance(x, str | int | float | bool) for x in v)
    )


def write_json(path: Path, document: dict[str, Any]) -> None:
    """Write ``document`` as indented JSON (numpy scalars and arrays converted)."""

    def default(obj: Any) -> Any:
        if hasattr(obj, "tolist"):  # numpy arrays and scalars
            return obj.tolist()
        if isinstance(obj, complex):
            return [obj.real, obj.imag]
        if isinstance(obj, Path):
            return str(obj)
        raise TypeError(f"not JSON-serialisable: {type(obj).__name__}")

    Path(path).write_text(json.dumps(document, indent=2, default=default) + "\n")
