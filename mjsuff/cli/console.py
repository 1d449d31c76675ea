"""Where the command line writes: tables and results to stdout, progress and errors to stderr."""

from __future__ import annotations

import math
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

EXIT_USAGE = 2
#: The Ray cluster at --address cannot be reached or refused the connection (sysexits.h's
#: EX_UNAVAILABLE): not bad input; nothing is written.
EXIT_CLUSTER = 69
#: Results could not be written mid-run (sysexits.h's EX_IOERR): ``RunWriteError``.
EXIT_WRITE = 74
#: Python ran out of memory (sysexits.h's EX_OSERR).
EXIT_MEMORY = 71
EXIT_INTERRUPTED = 130

#: Width of stdout off a terminal: wide enough that no table is cut and no line is wrapped.
LOG_WIDTH = 10_000


class _Stdout:
    """stdout through rich: on a terminal, fitted to the window; elsewhere (``> log``, a pipe) at
    full width, since rich would fit every table to 80 columns and cut its cells with "…"."""

    def __init__(self) -> None:
        self._terminal = Console()
        self._log = Console(width=LOG_WIDTH)

    def print(self, *objects: Any, **kwargs: Any) -> None:
        console = self._terminal if self._terminal.is_terminal else self._log
        console.print(*objects, **kwargs)


err = Console(stderr=True)
out = _Stdout()


def say(message: str) -> None:
    """One plain line on stdout (not wrapped; brackets in it are text, not markup)."""
    out.print(escape(message), highlight=False, soft_wrap=True)


def note(message: str) -> None:
    """One plain line on stderr: an interruption, a hint."""
    err.print(escape(message), highlight=False, soft_wrap=True)


def error(message: str) -> None:
    """The one line an error gets, on stderr."""
    err.print(f"[red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)


def warning(message: str) -> None:
    err.print(f"[yellow]warning:[/] {escape(message)}", highlight=False, soft_wrap=True)


def fmt(x: Any, digits: int = 2) -> str:
    """A table cell: "–" for a missing value or NaN, floats to ``digits`` decimals."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def progress_bar(quiet: bool, *, detail: bool = True, remaining: bool = True) -> Progress:
    """A progress bar on stderr (none with ``quiet``): description, bar, the task's ``detail``
    field (or ``completed/total``), elapsed and, with ``remaining``, the time left."""
    columns: list[Any] = [
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[detail]}" if detail else "{task.completed}/{task.total}"),
        TimeElapsedColumn(),
    ]
    if remaining:
        columns.append(TimeRemainingColumn())
    return Progress(*columns, console=err, disable=quiet)
