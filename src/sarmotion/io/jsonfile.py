"""Writing a JSON document (the command line's results, tracks, separation and peaks files).

JSON has no NaN nor infinity (RFC 8259): Python's ``json`` would write the bare words
``NaN`` and ``Infinity``, which strict readers refuse. A non-finite number, wherever it
comes from (a quantity not measured, an input's metadata), is written as ``null``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

__all__ = ["finite_or_null", "write_json"]


def finite_or_null(obj: Any) -> Any:
    """``obj`` with every non-finite float (NaN, +-inf) replaced by None, recursively.

    numpy arrays and scalars become lists and Python numbers, complex numbers
    ``[real, imag]``, paths strings; dicts, lists and tuples are walked.
    """
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite_or_null(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite_or_null(v) for v in obj]
    if hasattr(obj, "tolist"):  # numpy arrays and scalars
        return finite_or_null(obj.tolist())
    if isinstance(obj, complex):
        return [finite_or_null(obj.real), finite_or_null(obj.imag)]
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: Path, document: dict[str, Any]) -> None:
    """Write ``document`` as indented, strict JSON: non-finite numbers as ``null``.

    numpy scalars and arrays, complex numbers and paths are converted
    (:func:`finite_or_null`); any other object that JSON cannot hold is a TypeError.
    """
    text = json.dumps(finite_or_null(document), indent=2, allow_nan=False)
    Path(path).write_text(text + "\n")
