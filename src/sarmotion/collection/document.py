"""The ``sarmotion.collection/1`` document: a collection's analysis as JSON-ready data.

Top-level keys: ``schema``, ``reference_point_m``, ``n_pulses``, ``n_samples``,
``region_m``, ``plan`` (core side, the movers' margins, the unambiguous scene and the
patch table: each patch's core, centre, pulses, samples, decimation, pass band),
``movers`` (each patch's ``sarmotion.results/2`` mover entry, plus ``patch``, the patch
whose fit was kept, and ``patches``, every patch that found it; the entry's ``range_m``
and its family are measured from that patch's centre, ``plan.patches[patch].centre_m``,
its reference point), ``stationary``
(position, level in dB re the brightest of the mosaic, patch), ``stationary_dropped``
(targets beyond the cap, not listed), ``stationary_sidelobes_dropped`` (listings taken
for a brighter target's sidelobes, :func:`~sarmotion.collection.merge.drop_sidelobes`),
``stationary_mover_images_dropped`` (listings on a found mover's echo,
:func:`~sarmotion.collection.merge.drop_mover_images`),
``movers_not_estimated`` (the candidates that passed a patch's detector after
``max_movers`` movers of that patch were estimated, each patch's strongest first, as the
single analysis's ``sarmotion.results/2`` entries -- ``range_speed_mps``,
``statistic_db``, ``width_resolutions``, ``range_m`` -- plus ``patch``; ``range_m`` is
the ground range from that patch's centre, its reference point; a mover seen by two
neighbouring patches may be listed by both), ``patch_summaries`` (per patch: movers,
candidates not estimated, stationary targets listed, whether its own cap was reached,
method, timings), ``timings_s``, ``options``, ``source``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..core.blocks import PulseBlocks
from .run import CollectionResult

__all__ = ["COLLECTION_SCHEMA", "collection_document"]

#: Schema name of the collection document.
COLLECTION_SCHEMA = "sarmotion.collection/1"


def collection_document(result: CollectionResult, source: PulseBlocks) -> dict[str, Any]:
    """The ``sarmotion.collection/1`` document of ``result`` (lists, floats, strings)."""
    peak = max([t.level for t in result.stationary], default=0.0)
    movers = []
    for rec, patches in result.movers:
        entry = dict(rec.document)
        entry["patch"] = int(rec.patch)
        entry["patches"] = [int(p) for p in patches]
        movers.append(entry)
    return {
        "schema": COLLECTION_SCHEMA,
        "reference_point_m": [float(v) for v in source.reference_point_m],
        "n_pulses": int(source.n_pulses),
        "n_samples": int(source.radar.n_samples),
        "region_m": [float(v) for v in result.plan.region_m],
        "plan": result.plan.to_dict(),
        "movers": movers,
        "stationary": [
            {
                "position_m": [float(v) for v in t.position_m],
                "peak_db": float(20 * np.log10(max(t.level, 1e-300) / peak)) if peak > 0 else 0.0,
                "patch": int(t.patch),
            }
            for t in result.stationary
        ],
        "movers_not_estimated": [
            {**{k: float(v) for k, v in dataclasses.asdict(c).items()}, "patch": int(r.index)}
            for r in result.patches
            for c in r.not_estimated
        ],
        "stationary_dropped": int(result.stationary_dropped),
        "stationary_sidelobes_dropped": int(result.stationary_sidelobes),
        "stationary_mover_images_dropped": int(result.stationary_mover_images),
        "patch_summaries": [
            {
                "index": r.index,
                "movers": len(r.movers),
                "movers_not_estimated": len(r.not_estimated),
                "stationary_listed": r.listed,
                "stationary_cap_reached": bool(r.capped),
                "method": r.method,
                "n_pulses": r.n_pulses,
                "n_samples": r.n_samples,
                "timings_s": {k: float(v) for k, v in r.timings_s.items()},
            }
            for r in result.patches
        ],
        "timings_s": {k: float(v) for k, v in result.timings_s.items()},
        "options": {**result.options.to_dict(), "analysis": result.options.analysis.to_dict()},
        "source": {
            k: v for k, v in source.metadata.items() if isinstance(v, str | int | float | bool)
        },
    }
