"""Signatures of the science layers: at most 12 parameters, data first.

A function with more than 12 parameters wants an options object or a record; numba
kernels (whose arguments are arrays and scalars by necessity) and click commands (one
parameter per option) are exempt. Checked on the source with :mod:`ast`, in the
packages whose signatures follow the rule "data first, the acquisition as a keyword".
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "sarmotion"
PACKAGES = ("core", "motion", "pipeline", "separation")
MAX_PARAMETERS = 12


def _exempt(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    names = [ast.unparse(d) for d in node.decorator_list]
    return any("jit" in n or "intrinsic" in n or "click" in n for n in names)


def _parameters(node: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    a = node.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return names + [x.arg for x in (a.vararg, a.kwarg) if x is not None]


def _functions(package: str):
    for path in sorted((SRC / package).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and not _exempt(node):
                yield path, node


@pytest.mark.parametrize("package", PACKAGES)
def test_no_function_takes_more_than_12_parameters(package):
    too_many = [
        f"{path.relative_to(SRC)}:{node.lineno} {node.name} ({len(_parameters(node))})"
        for path, node in _functions(package)
        if len(_parameters(node)) > MAX_PARAMETERS
    ]
    assert not too_many, too_many


def test_the_check_sees_a_long_signature():
    """The counter counts positional, keyword-only and star parameters, not ``self``."""
    node = ast.parse("class A:\n def f(self, a, b, /, c, *d, e, f=1, **g): pass").body[0].body[0]
    assert _parameters(node) == ["a", "b", "c", "e", "f", "d", "g"]
