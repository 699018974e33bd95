"""The documents sarmotion writes and the one it reads beside its data.

One module per document, each a function from result objects to JSON-ready data (lists,
floats, strings) and the schema name it carries:

* :mod:`~sarmotion.documents.results` -- ``sarmotion.results/3``, an analysis of any size
  (:func:`sarmotion.pipeline.analyze`, one patch; :func:`sarmotion.collection.analyze_collection`,
  several merged);
* :mod:`~sarmotion.documents.tracks` -- ``sarmotion.tracks/1``, the movers followed across
  sub-apertures (:func:`sarmotion.tracking.track`);
* :mod:`~sarmotion.documents.separation` -- ``sarmotion.separation/1``, a separation;
* :mod:`~sarmotion.documents.peaks` -- ``sarmotion.peaks/1``, the brightest points of an
  image;
* :mod:`~sarmotion.documents.roads` -- GeoJSON road centre lines, read into
  :class:`sarmotion.tracking.Road`.

Each carries ``$schema``, the ``$id`` of its JSON Schema, shipped in the package and read
by :func:`~sarmotion.documents.schema.load_schema` (:mod:`~sarmotion.documents.schema`).

This layer sits above :mod:`sarmotion.pipeline` and :mod:`sarmotion.tracking`, whose
results it describes; :func:`sarmotion.io.write_json` writes a document to a file.
"""

from typing import TYPE_CHECKING

from .._lazy import attach

if TYPE_CHECKING:
    from .peaks import PEAKS_SCHEMA, peaks_document
    from .results import RESULTS_SCHEMA, collection_document, results_document
    from .roads import read_roads
    from .schema import load_schema, validate
    from .separation import SEPARATION_SCHEMA, separation_document
    from .tracks import TRACKS_SCHEMA, tracks_document

# Imported on first use (PEP 562): the results document needs the pipeline and the tracks
# document Stone Soup, neither of which a command that writes peaks should load.
_LAZY = {
    "PEAKS_SCHEMA": ".peaks",
    "RESULTS_SCHEMA": ".results",
    "SEPARATION_SCHEMA": ".separation",
    "TRACKS_SCHEMA": ".tracks",
    "peaks_document": ".peaks",
    "read_roads": ".roads",
    "results_document": ".results",
    "collection_document": ".results",
    "load_schema": ".schema",
    "validate": ".schema",
    "separation_document": ".separation",
    "tracks_document": ".tracks",
}

__all__ = [
    "PEAKS_SCHEMA",
    "RESULTS_SCHEMA",
    "SEPARATION_SCHEMA",
    "TRACKS_SCHEMA",
    "collection_document",
    "load_schema",
    "peaks_document",
    "read_roads",
    "results_document",
    "separation_document",
    "tracks_document",
    "validate",
]

__getattr__, __dir__ = attach(__name__, _LAZY)
