"""The package's layers: every import in ``src/sarmotion`` runs down the layers, never up.

From the bottom:

1. ``core`` with the package's own helpers ``_validation``, ``_version``, ``_limits`` (the
   memory budget), ``_lazy`` (names imported on first use) and ``errors``;
2. science, arrays in and arrays out: ``simulation`` and ``imaging`` import only the
   base; ``separation`` and ``motion`` import the base and ``imaging`` (neither imports
   the other nor ``simulation``);
3. ``io``, acquisition formats: only the base; ``sources`` (any input as traces or
   blocks: scenes simulated, files read) the base, ``simulation`` and ``io``;
4. ``pipeline`` (the analysis: the science layers, and ``simulation`` to compare with
   the truth), then ``tracking`` (also ``pipeline``);
5. ``documents`` (also ``io``, ``pipeline``, ``tracking``), then ``report`` (also
   ``documents``);
6. the paper wing: ``paper.rank`` is science (the base and ``simulation``), the rest of
   ``paper`` (its figures) stands above ``report``;
7. ``cli``: anything. The top-level package (its lazily imported names) and
   ``__main__`` stand above all; no module below them imports the top-level package.

matplotlib is imported only by the report layer: ``report`` and the paper's figures. Each
import statement is read from the source (``ast``), whether it runs at import time, inside
a function or only for type checking: a lazy import that runs up the layers still ties
the layers together.
"""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "sarmotion"

BASE = {"core", "_validation", "_version", "_limits", "_lazy", "_cluster", "errors"}
SCIENCE_LOW = BASE | {"simulation", "imaging"}
SCIENCE = SCIENCE_LOW | {"separation", "motion"}

#: Each part of the package and the parts it may import (besides its own).
MAY_IMPORT: dict[str, set[str]] = {
    "core": {"_validation", "_version", "_limits", "errors"},
    "_validation": set(),
    "_limits": set(),
    "_cluster": {"errors"},
    "_lazy": set(),
    "_version": set(),
    "errors": set(),
    "simulation": BASE,
    "imaging": BASE,
    "separation": BASE | {"imaging"},
    "motion": BASE | {"imaging"},
    "io": BASE,
    "sources": BASE | {"simulation", "io"},
    "pipeline": SCIENCE,
    "tracking": SCIENCE | {"pipeline"},
    "collection": SCIENCE | {"pipeline"},
    "documents": SCIENCE | {"io", "pipeline", "tracking", "collection"},
    "report": SCIENCE | {"io", "pipeline", "tracking", "collection", "documents"},
    "paper.rank": BASE | {"simulation"},
    "paper": SCIENCE
    | {"io", "pipeline", "tracking", "collection", "documents", "report", "paper.rank"},
    "cli": SCIENCE
    | {"io", "sources", "pipeline", "tracking", "collection", "documents", "report", "paper"},
    "__main__": {"cli"},
}

#: Subpackages that form a part of their own, in a layer apart from their parent's.
SUBPARTS = {"paper.rank"}

#: Parts that may import matplotlib.
PLOTTING = {"report", "paper"}


def _module_name(path: Path, src: Path) -> tuple[str, bool]:
    """Dotted name of the module at ``path`` and whether it is a package ``__init__``."""
    parts = list(path.relative_to(src).with_suffix("").parts)
    if parts[-1] == "__init__":
        return ".".join(parts[:-1]), True
    return ".".join(parts), False


def _exists(dotted: str, src: Path) -> bool:
    base = src.joinpath(*dotted.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _imports(path: Path, src: Path) -> list[tuple[int, str]]:
    """``(line, dotted target)`` of every import in the file at ``path``.

    ``from pkg import name`` targets ``pkg.name`` when that is a module, else ``pkg``.
    """
    name, is_package = _module_name(path, src)
    here = name.split(".") if is_package else name.split(".")[:-1]
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(
                    here[: len(here) - node.level + 1] + ([node.module] if node.module else [])
                )
            else:
                base = node.module or ""
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.append((node.lineno, sub if _exists(sub, src) else base))
    return out


def _part(dotted: str) -> str | None:
    """The part of the package ``dotted`` belongs to; ``""`` for the top-level package."""
    parts = dotted.split(".")
    if parts[0] != PACKAGE:
        return None
    if ".".join(parts[1:3]) in SUBPARTS:
        return ".".join(parts[1:3])
    return parts[1] if len(parts) > 1 else ""


def layering_violations(src: Path = SRC) -> list[str]:
    """One line per import that runs up the layers or imports matplotlib outside report."""
    bad = []
    for path in sorted((src / PACKAGE).rglob("*.py")):
        name, _ = _module_name(path, src)
        part = _part(name)
        if part == "":  # the top-level package re-exports names lazily from any layer
            continue
        allowed = MAY_IMPORT.get(part)
        where = f"{path.relative_to(src.parent)}"
        if allowed is None:
            bad.append(f"{where}: part {part!r} has no place in the layers (tests/test_layering)")
            continue
        for line, target in sorted(set(_imports(path, src))):
            if target.split(".")[0] == "matplotlib" and part not in PLOTTING:
                bad.append(f"{where}:{line}: imports {target} outside the report layer")
            other = _part(target)
            if other is None or other == part:
                continue
            if other == "":
                bad.append(f"{where}:{line}: imports the top-level package {PACKAGE}")
            elif other not in allowed:
                bad.append(f"{where}:{line}: {part} imports {target}, a layer above or beside it")
    return bad


def test_imports_run_down_the_layers():
    bad = layering_violations()
    assert not bad, "imports against the layers:\n" + "\n".join(bad)


def test_every_part_of_the_package_has_a_layer():
    top = SRC / PACKAGE
    modules = {p.stem for p in top.glob("*.py") if p.stem != "__init__"}
    packages = {p.parent.name for p in top.glob("*/__init__.py")}
    assert modules | packages <= set(MAY_IMPORT), sorted((modules | packages) - set(MAY_IMPORT))


@pytest.mark.parametrize(
    ("part", "source", "expected"),
    [
        ("io", "from ..pipeline import analyze\n", "io imports sarmotion.pipeline"),
        ("separation", "def f():\n    from ..motion import x\n", "separation imports"),
        ("core", "from .. import __version__\n", "imports the top-level package"),
        ("motion", "import matplotlib.pyplot as plt\n", "outside the report layer"),
        ("paper/rank", "from ...report import plotting\n", "paper.rank imports"),
    ],
)
def test_an_upward_import_is_found(tmp_path, part, source, expected):
    """The check itself: a copy of the package with one upward import added fails it."""
    copy = tmp_path / "src"
    shutil.copytree(SRC / PACKAGE, copy / PACKAGE, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / PACKAGE / part / "_upward.py").write_text(source)
    new = sorted(set(layering_violations(copy)) - set(layering_violations()))
    assert len(new) == 1 and expected in new[0], new
