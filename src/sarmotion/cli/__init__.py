"""The command line: ``sarmotion simulate | image | inject | separate | analyze | convert | ...``.

Commands parse their options, call the library and write their outputs; shared options
are declared once (:mod:`~sarmotion.cli.common`). Bad input never shows a traceback: one
line on stderr (``sarmotion: error: ...``) and exit status 2; outputs are staged in a
hidden sibling directory and moved into place only on success.
"""

from .main import entry_point, main, run

__all__ = ["entry_point", "main", "run"]
