"""The ``mjsuff`` command's entry point: a Ctrl-C while the command is still importing is one line.

Importing the commands (numpy, scipy, MuJoCo, ArviZ) takes a second or more. A Ctrl-C in that
time would otherwise end with Python's ``KeyboardInterrupt`` traceback or, when it lands inside an
extension module's initialization, an ``ImportError``. This module imports only the standard
library, and neither do ``mjsuff/__init__.py`` nor ``mjsuff/cli/__init__.py`` import anything
heavy, so the ``try`` below is in place before the slow imports start.
"""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType

#: Exit status of an interrupted command (128 + SIGINT), as ``mjsuff.cli.console.EXIT_INTERRUPTED``.
EXIT_INTERRUPTED = 130

STARTUP_INTERRUPTED = "mjsuff: interrupted while starting; nothing was written"


def main(argv: list[str] | None = None) -> int:
    """Import the commands, then run one (:func:`mjsuff.cli.commands.run_command`); a Ctrl-C before
    they are imported prints :data:`STARTUP_INTERRUPTED` and returns :data:`EXIT_INTERRUPTED`.

    Only a Ctrl-C that would raise ``KeyboardInterrupt`` anyway is taken over (SIGINT's handler
    is a Python function, in the main thread): an ignored SIGINT stays ignored."""
    interrupted = False

    def interrupt(signum: int, frame: FrameType | None) -> None:
        nonlocal interrupted
        interrupted = True
        raise KeyboardInterrupt

    previous = signal.getsignal(signal.SIGINT)
    replace = callable(previous) and threading.current_thread() is threading.main_thread()
    if replace:
        signal.signal(signal.SIGINT, interrupt)
    try:
        from mjsuff.cli.commands import run_command
    except BaseException:
        # A Ctrl-C can surface as a KeyboardInterrupt or, inside an extension module's
        # initialization, as an ImportError or SystemError: whatever it was, it is the Ctrl-C.
        if not interrupted:
            raise
        return _startup_interrupted()
    finally:
        if replace:
            signal.signal(signal.SIGINT, previous)
    if interrupted:
        # Swallowed inside an import (some libraries catch exceptions around optional imports).
        return _startup_interrupted()
    return run_command(argv)


def _startup_interrupted() -> int:
    print(STARTUP_INTERRUPTED, file=sys.stderr)
    return EXIT_INTERRUPTED
