"""Signatures across the package: at most 12 parameters.

A function with more than 12 parameters wants an options object or a record. Exempt, as
read from their decorators: numba kernels (``jit``, ``njit``, ``intrinsic``, ``cuda.jit``:
their arguments are arrays and scalars by necessity) and click commands (one parameter per
option). Checked on the source with :mod:`ast`, in every module under ``src/sarmotion``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "sarmotion"
MAX_PARAMETERS = 12
#: Last names of the decorators that compile a numba kernel.
NUMBA_DECORATORS = {"jit", "njit", "intrinsic", "generated_jit", "vectorize", "guvectorize"}
#: Last names of the decorators that make a click command.
CLICK_DECORATORS = {"command", "group"}

#: Every part of the package: its subpackages and, as ``"."``, its top-level modules.
PARTS = sorted(p.name for p in SRC.iterdir() if (p / "__init__.py").is_file()) + ["."]


def _callee(decorator: ast.expr) -> str:
    """``numba.njit`` of ``@numba.njit(parallel=True)``: the decorator without its call."""
    return ast.unparse(decorator.func if isinstance(decorator, ast.Call) else decorator)


def _exempt(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    for decorator in node.decorator_list:
        name = _callee(decorator)
        last = name.rsplit(".", 1)[-1]
        if last in NUMBA_DECORATORS:
            return True
        if last in CLICK_DECORATORS and "." in name:  # click.command, cli.command
            return True
    return False


def _parameters(node: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    a = node.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return names + [x.arg for x in (a.vararg, a.kwarg) if x is not None]


def _files(part: str) -> list[Path]:
    if part == ".":
        return sorted(SRC.glob("*.py"))
    return sorted((SRC / part).rglob("*.py"))


def _functions(part: str):
    for path in _files(part):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and not _exempt(node):
                yield path, node


@pytest.mark.parametrize("part", PARTS)
def test_no_function_takes_more_than_12_parameters(part):
    too_many = [
        f"{path.relative_to(SRC)}:{node.lineno} {node.name} ({len(_parameters(node))})"
        for path, node in _functions(part)
        if len(_parameters(node)) > MAX_PARAMETERS
    ]
    assert not too_many, too_many


def test_every_module_is_checked():
    """The parts cover every module of the package, and there are modules to check."""
    covered = {path for part in PARTS for path in _files(part)}
    assert covered == set(SRC.rglob("*.py"))
    assert {"cli", "imaging", "pipeline", "tracking"} <= set(PARTS)


def test_the_check_sees_a_long_signature():
    """The counter counts positional, keyword-only and star parameters, not ``self``."""
    node = ast.parse("class A:\n def f(self, a, b, /, c, *d, e, f=1, **g): pass").body[0].body[0]
    assert _parameters(node) == ["a", "b", "c", "e", "f", "d", "g"]


@pytest.mark.parametrize(
    ("decorators", "exempt"),
    [
        ("@numba.njit(parallel=True, cache=True)", True),
        ("@njit", True),
        ("@cuda.jit", True),
        ("@intrinsic", True),
        ("@click.command()\n@click.option('--x')", True),
        ("@main.command(name='x')", True),
        ("@click_helper", False),
        ("@functools.cache", False),
        ("@jitter.wrap", False),
        ("", False),
    ],
)
def test_the_exemptions_are_read_from_the_decorators(decorators, exempt):
    """Only numba kernels and click commands are exempt, whatever their names."""
    node = ast.parse(f"{decorators}\ndef kernel_click_jit(a): pass").body[0]
    assert _exempt(node) is exempt
