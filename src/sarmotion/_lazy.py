"""Names of a package imported on first use (PEP 562), with a clean ``dir()``.

``import sarmotion`` and the command line's start-up should not pay for numba, scipy,
matplotlib or Stone Soup before a name that needs them is used. A package lists its
public names and the modules that hold them, and :func:`attach` gives it the module
``__getattr__`` and ``__dir__`` that import a name's module on first use:

>>> __getattr__, __dir__ = attach(__name__, {"analyze": ".pipeline"})  # doctest: +SKIP
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from importlib import import_module

__all__ = ["attach"]


def attach(
    package: str, names: Mapping[str, str], *, eager: tuple[str, ...] = ()
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package`` for its lazily imported names.

    Parameters
    ----------
    package : str
        The ``__name__`` of the package (or module) that offers the names.
    names : mapping of str to str
        Each public name and the module that defines it, relative to the package (for a
        module, to the package it is in), e.g. ``".pipeline"``.
    eager : tuple of str
        Public names the package defines itself (listed by ``dir()`` with ``names``).

    Returns
    -------
    (__getattr__, __dir__)
        ``__getattr__(name)`` imports the name's module once and caches the value in the
        package's namespace; ``__dir__()`` lists the public names only (not the
        package's own imports).
    """
    table = dict(names)

    def __getattr__(name: str) -> object:
        if name in table:
            module = sys.modules[package]
            anchor = module.__package__ or package  # a module's names: its package's modules
            value = getattr(import_module(table[name], anchor), name)
            setattr(sys.modules[package], name, value)
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted({*table, *eager})

    return __getattr__, __dir__
