"""The ``mjsuff`` command line: one module per command, assembled by :mod:`mjsuff.cli.commands`.

Each command module offers ``add_parser(commands)``, which adds its sub-parser and sets its
``func``. A command reports bad input by raising an :class:`~mjsuff.errors.MjsuffError`; ``main``
prints it as one line and exits with its ``exit_code``. Anything else is a bug and keeps its
traceback.

``main`` is :func:`mjsuff.cli.entry.main`, which imports the commands only once it can turn a
Ctrl-C during that import into one line; ``build_parser`` is imported on first use for the same
reason (nothing heavy is imported with this package).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mjsuff.cli.entry import main

__all__ = ["build_parser", "main"]

if TYPE_CHECKING:  # type checkers see the name itself (and a misspelt one is an error)
    from mjsuff.cli.commands import build_parser
else:

    def __getattr__(name: str) -> Any:
        """``build_parser`` is imported on first use (it imports every command)."""
        if name == "build_parser":
            from mjsuff.cli.commands import build_parser

            return build_parser
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
