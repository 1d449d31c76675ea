"""The errors mjsuff reports to its user as one line.

Every error that says "this input cannot be used" or names a fault mjsuff can explain derives from
``MjsuffError``; the CLI catches these, and only these, prints the message and exits with the
error's ``exit_code``. Anything else is a bug and keeps its traceback. Each subclass also derives
from the builtin it refines (``ValueError``, ``OSError``, ...), so callers that catch those still do.
"""

from __future__ import annotations


class MjsuffError(Exception):
    """Base of the errors reported as one line; the message names the file, key or option."""

    #: The CLI's exit status for this error (2: bad input, nothing written).
    exit_code: int = 2


class UsageError(MjsuffError, ValueError):
    """A command-line value that cannot be used (the message names the option)."""


def in_context(where: str, exc: MjsuffError) -> MjsuffError:
    """``exc`` restated as ``"{where}: {exc}"`` (the file or option it concerns), keeping its exit
    status, for a caller that knows where the input came from and the raiser did not."""
    restated = MjsuffError(f"{where}: {exc}")
    restated.exit_code = exc.exit_code
    return restated
