"""Writing a JSON document (the command line's results, tracks, separation and peaks files)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["write_json"]


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
