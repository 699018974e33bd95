"""The package version, in a module of its own so that any layer can name it.

``sarmotion/__init__.py`` re-exports it; the I/O and report layers write it into the files
they produce without importing the top-level package.
"""

__version__ = "0.1.0"
