"""``DeferredSignals``: SIGINT and SIGTERM held back until a point the caller chooses.

Why: ``concurrent.futures.wait`` takes every future's lock in turn. A ``KeyboardInterrupt``
raised there by a signal handler can leave some of those locks held by the main thread; the
pool's manager thread, which sets results under them, then blocks for good, and so does
``ProcessPoolExecutor.shutdown(wait=True)``: a Ctrl-C that hangs the run instead of stopping it
(seen about once in a hundred interrupted runs under load; reproduced with a thread finishing
futures while the main thread waits on them).
"""

from __future__ import annotations

import signal
import threading
from types import FrameType, TracebackType
from typing import Any

DEFERRED = (signal.SIGINT, signal.SIGTERM)


class DeferredSignals:
    """While active, a SIGINT or SIGTERM is recorded instead of handled; ``deliver()`` hands the
    recorded one to its usual handler (for Ctrl-C: raise ``KeyboardInterrupt``) where the caller
    calls it. A second signal before that is handled at once, so a stuck program still stops on
    a second Ctrl-C.

    Only signals whose handler is a Python function are deferred (SIGTERM is, inside
    ``mjsuff.cli.signals.sigterm_interrupts``); an ignored or default-action signal keeps its
    disposition. Signal handlers belong to the main thread: in any other thread this does
    nothing. Not reentrant.
    """

    def __init__(self) -> None:
        self._previous: dict[int, Any] = {}
        self._pending: int | None = None

    def __enter__(self) -> DeferredSignals:
        if threading.current_thread() is not threading.main_thread():
            return self
        for signum in DEFERRED:
            handler = signal.getsignal(signum)
            if callable(handler):
                self._previous[signum] = signal.signal(signum, self._record)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Put the usual handlers back. A signal still pending is dropped when an exception is
        already going up (the work is stopping anyway), else delivered."""
        previous, self._previous = self._previous, {}
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if exc_type is None and self._pending is not None:
            signum, self._pending = self._pending, None
            previous[signum](signum, None)

    @property
    def pending(self) -> bool:
        """Whether a signal arrived that ``deliver()`` has not handed on yet."""
        return self._pending is not None

    def deliver(self) -> None:
        """Handle the signal recorded since the last call, if any, with its usual handler."""
        if self._pending is None:
            return
        signum, self._pending = self._pending, None
        self._previous[signum](signum, None)

    def _record(self, signum: int, frame: FrameType | None) -> None:
        if self._pending is not None:  # the second one: no more waiting
            self._pending = None
            self._previous[signum](signum, frame)
            return
        self._pending = signum
