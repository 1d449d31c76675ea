"""``DeferredSignals``: SIGINT and SIGTERM held back to the end of a short block.

Why: ``concurrent.futures.wait`` takes every future's lock in turn. A ``KeyboardInterrupt``
raised there by a signal handler can leave some of those locks held by the main thread; the
pool's manager thread, which sets results under them, then blocks for good, and so does
``ProcessPoolExecutor.shutdown(wait=True)``: an interrupted run that never ends (seen twice in
CI under load; ``benchmarks/interrupt_in_wait.py`` shows the window).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from types import FrameType, TracebackType

_DEFERRED = (signal.SIGINT, signal.SIGTERM)

_Handler = Callable[[int, FrameType | None], object]


class DeferredSignals:
    """Inside the block, a SIGINT or SIGTERM is recorded instead of handled; on leaving it, the
    first one recorded goes to its usual handler (for Ctrl-C: ``KeyboardInterrupt``, raised
    there), unless an exception is already going up. Meant for short blocks (a bounded wait):
    further signals inside the block add nothing.

    Only signals whose handler is a Python function are deferred (SIGTERM is, inside
    ``mjsuff.cli.signals.sigterm_interrupts``); an ignored or default-action signal keeps its
    disposition. Signal handlers belong to the main thread: in any other thread this does
    nothing. One block per instance at a time.
    """

    def __init__(self) -> None:
        self._previous: dict[int, _Handler] = {}
        self._pending: int | None = None
        self._open = False

    def __enter__(self) -> DeferredSignals:
        if threading.current_thread() is not threading.main_thread():
            return self
        self._pending, self._open = None, True
        for signum in _DEFERRED:
            handler = signal.getsignal(signum)
            if callable(handler):
                self._previous[signum] = handler
                signal.signal(signum, self._record)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._open = False  # from here a signal goes straight to its usual handler
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        pending, self._pending = self._pending, None
        if pending is not None and exc_type is None:
            self._previous[pending](pending, None)

    def _record(self, signum: int, frame: FrameType | None) -> None:
        if not self._open:  # arrived while the handlers were being put back
            self._previous[signum](signum, frame)
        elif self._pending is None:
            self._pending = signum
