"""The JSON Schemas of the documents sarmotion writes, shipped inside the package.

Each document carries ``schema`` (its name and version, e.g. ``sarmotion.results/3``)
and ``$schema``, the ``$id`` of the JSON Schema (draft 2020-12) that describes every key
of it: ``urn:sarmotion:schema:<kind>:<version>``. The schemas are package data
(``sarmotion/documents/schemas/*.json``), read with :mod:`importlib.resources`, so an
installed sarmotion validates its own outputs without the source tree:

>>> from sarmotion.documents.schema import load_schema
>>> load_schema("sarmotion.peaks/1")["$id"]
'urn:sarmotion:schema:peaks:1'

:func:`validate` checks a document against its schema with the ``jsonschema`` package
(in the ``test`` extra; not needed to write documents).
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

__all__ = ["SCHEMA_FILES", "load_schema", "schema_uri", "stamped", "validate"]

#: The file of each document's schema under ``sarmotion/documents/schemas``.
SCHEMA_FILES = {
    "sarmotion.results/3": "results.json",
    "sarmotion.tracks/1": "tracks.json",
    "sarmotion.peaks/1": "peaks.json",
    "sarmotion.separation/1": "separation.json",
}


def schema_uri(name: str) -> str:
    """The ``$id`` of the schema of document ``name`` (``"sarmotion.results/3"``)."""
    kind, _, version = name.removeprefix("sarmotion.").partition("/")
    if not kind or not version:
        raise ValueError(f"not a sarmotion document name: {name!r}")
    return f"urn:sarmotion:schema:{kind}:{version}"


@cache
def _text(name: str) -> str:
    try:
        file = SCHEMA_FILES[name]
    except KeyError:
        raise ValueError(
            f"no schema for {name!r}; known: {', '.join(sorted(SCHEMA_FILES))}"
        ) from None
    return resources.files(__package__).joinpath("schemas", file).read_text(encoding="utf-8")


def load_schema(name: str) -> dict[str, Any]:
    """The JSON Schema (a new dict) of document ``name``, e.g. ``"sarmotion.results/3"``."""
    return json.loads(_text(name))


def stamped(name: str, body: dict[str, Any]) -> dict[str, Any]:
    """``body`` led by ``$schema`` (the schema's ``$id``) and ``schema`` (``name``)."""
    return {"$schema": schema_uri(name), "schema": name, **body}


def validate(document: dict[str, Any]) -> list[str]:
    """The ways ``document`` departs from its schema (empty when it validates).

    The schema is chosen by the document's ``schema`` key; its ``$schema`` must be that
    schema's ``$id``. Needs ``jsonschema`` (the ``test`` extra).

    Returns
    -------
    list of str
        One line per violation: the path in the document and the message.
    """
    import jsonschema

    name = document.get("schema")
    if name not in SCHEMA_FILES:
        return [f"schema: {name!r} is not one of {sorted(SCHEMA_FILES)}"]
    schema = load_schema(name)
    validator = jsonschema.Draft202012Validator(schema)
    return [
        f"{'/'.join(str(p) for p in e.absolute_path) or '(document)'}: {e.message}"
        for e in sorted(validator.iter_errors(document), key=lambda e: list(e.absolute_path))
    ]
