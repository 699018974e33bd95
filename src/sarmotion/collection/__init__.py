"""Whole collections: scenes of any size cut into patches, analysed one patch at a time.

- :mod:`~sarmotion.collection.plan` — :func:`plan_patches`: the patches' cores, windows and
  slow-time filters, sized from the data;
- :mod:`~sarmotion.collection.extract` — :func:`extract_patches`: each patch's traces,
  re-referenced to its centre, windowed and decimated, built block by block;
- :mod:`~sarmotion.collection.merge` — one mover per range history, stationary targets
  de-duplicated, the stationary mosaic;
- :mod:`~sarmotion.collection.run` — :func:`analyze_collection`: the patches as tasks
  (Dask or in process) and their merged result;
- :mod:`~sarmotion.collection.analysis` — :func:`analyze_source`: any source planned,
  analysed and merged, one patch or many as its region needs, with one smear rule
  (what :func:`sarmotion.analyze` and ``sarmotion analyze`` run).

Its document is the analysis's, ``sarmotion.results/3``
(:func:`sarmotion.documents.results.collection_document`).
"""

from .analysis import analyze_source, collection_options
from .extract import PatchBuilder, extract_patches, patch_radar
from .merge import (
    MoverRecord,
    StationaryRecord,
    drop_sidelobes,
    merge_movers,
    merge_stationary,
    same_mover,
)
from .plan import (
    CollectionOptions,
    Patch,
    PatchPlan,
    RegionError,
    inscribed_box,
    plan_patches,
    unambiguous_scene,
)
from .run import CollectionResult, PatchResult, analyze_collection, analyze_patch, drop_smear

__all__ = [
    "CollectionResult",
    "MoverRecord",
    "PatchResult",
    "StationaryRecord",
    "analyze_collection",
    "analyze_source",
    "collection_options",
    "analyze_patch",
    "drop_smear",
    "drop_sidelobes",
    "merge_movers",
    "merge_stationary",
    "same_mover",
    "CollectionOptions",
    "Patch",
    "PatchBuilder",
    "PatchPlan",
    "RegionError",
    "extract_patches",
    "patch_radar",
    "plan_patches",
    "inscribed_box",
    "unambiguous_scene",
]
