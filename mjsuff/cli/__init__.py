"""The ``mjsuff`` command line: one module per command, assembled by :mod:`mjsuff.cli.main`.

Each command module offers ``add_parser(commands)``, which adds its sub-parser and sets its
``func``. A command reports bad input by raising an :class:`~mjsuff.errors.MjsuffError`; ``main``
prints it as one line and exits with its ``exit_code``. Anything else is a bug and keeps its
traceback.
"""

from mjsuff.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
