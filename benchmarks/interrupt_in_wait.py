"""Benchmark: does a Ctrl-C raised inside ``concurrent.futures.wait`` leave a future's lock held?

Why ``mjsuff.experiment.deferred_signals`` exists. ``LocalBackend`` waits on its replicates'
futures in the main thread while the pool's manager thread sets their results. A Ctrl-C (or a
SIGTERM turned into one) raises ``KeyboardInterrupt`` wherever the main thread is; inside
``wait()`` that can be between taking one future's lock and the next, so the locks taken so far
are never released. The manager thread then blocks on one of them for good and
``ProcessPoolExecutor.shutdown(wait=True)`` with it: an interrupted run that never ends (the
``test_interrupt_mid_run...`` hang, seen twice in CI under load).

Here a thread finishes many futures quickly while the main thread waits on them (as the manager
thread and the run do), and a SIGINT comes at a random moment. Printed per way of waiting: the
trials whose interrupt left a lock held, i.e. that would hang:

* ``raw``: ``wait()`` with Python's own SIGINT handler (the code before the fix);
* ``deferred``: each bounded wait inside ``DeferredSignals``, the signal handled as it ends (the fix).

    python benchmarks/interrupt_in_wait.py --trials 200
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import threading
import time
from concurrent.futures import FIRST_COMPLETED, Future, wait

from mjsuff.experiment.deferred_signals import DeferredSignals

FUTURES = 2000  # per trial: many, so that wait() spends its time taking locks


def trial(rng: random.Random, deferred: bool) -> bool:
    """One interrupted wait; True if the interrupt left a future's lock held by this thread."""
    futures = [Future() for _ in range(FUTURES)]
    for future in futures:
        future.set_running_or_notify_cancel()

    def finish() -> None:
        for future in futures:
            time.sleep(0.00002)
            future.set_result(None)  # blocks for good on a lock left held

    def interrupt() -> None:
        time.sleep(rng.uniform(0.001, 0.05))
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=finish, daemon=True).start()
    kicker = threading.Thread(target=interrupt)
    pending = set(futures)
    try:
        if deferred:
            kicker.start()
            while pending:
                with DeferredSignals():  # as LocalBackend.run waits
                    _, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
            kicker.join()
        else:
            kicker.start()
            while pending:
                _, pending = wait(pending, return_when=FIRST_COMPLETED)
            kicker.join()
    except KeyboardInterrupt:
        pass
    kicker.join()
    return any(f._condition._is_owned() for f in futures)  # type: ignore[attr-defined]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=200, help="interrupted waits per way (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the interrupt times")
    args = parser.parse_args()
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for deferred in (False, True):
        rng = random.Random(args.seed)
        started = time.perf_counter()
        held = sum(trial(rng, deferred) for _ in range(args.trials))
        name = "deferred" if deferred else "raw"
        print(
            f"{name:>8}: {held} of {args.trials} interrupts left a future's lock held "
            f"({time.perf_counter() - started:.0f} s)",
            flush=True,
        )


if __name__ == "__main__":
    main()
