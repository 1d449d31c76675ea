"""DeferredSignals: a Ctrl-C or SIGTERM inside the block is handled when it ends (once), the
usual handlers come back; the local backend takes a Ctrl-C mid-run and stops its worker."""

import multiprocessing
import os
import signal
import threading

import pytest

from mjsuff.cli.signals import sigterm_interrupts
from mjsuff.experiment.backend import ReplicateTask
from mjsuff.experiment.deferred_signals import DeferredSignals
from mjsuff.experiment.local_backend import LocalBackend
from tests.conftest import small_scenario


@pytest.fixture(autouse=True)
def usual_handlers():
    """Python's own SIGINT handler (a test run started in the background has SIGINT ignored) and
    SIGTERM's default action (earlier tests in this process may have set a handler)."""
    previous = {
        signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
        signal.SIGTERM: signal.signal(signal.SIGTERM, signal.SIG_DFL),
    }
    yield
    for signum, handler in previous.items():
        signal.signal(signum, handler)


def test_a_signal_inside_the_block_is_handled_when_it_ends_once():
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with DeferredSignals():
            signal.raise_signal(signal.SIGINT)  # its handler runs here: recorded, nothing raised
            signal.raise_signal(signal.SIGINT)  # adds nothing
            reached.append(True)
    assert reached == [True]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with DeferredSignals():  # nothing left over for the next block
        pass


def test_a_signal_is_dropped_when_an_error_is_already_going_up():
    with pytest.raises(ValueError):  # the error going up is the one reported
        with DeferredSignals():
            signal.raise_signal(signal.SIGINT)
            raise ValueError("stopping anyway")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_sigterm_is_deferred_only_where_it_interrupts():
    with pytest.raises(KeyboardInterrupt), sigterm_interrupts():
        with DeferredSignals():
            signal.raise_signal(signal.SIGTERM)
    # Elsewhere SIGTERM keeps its default action (to end the process), untouched.
    with DeferredSignals():
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_outside_the_main_thread_nothing_changes():
    seen = []

    def body():
        with DeferredSignals():
            seen.append(signal.getsignal(signal.SIGINT))

    thread = threading.Thread(target=body)
    thread.start()
    thread.join()
    assert seen == [signal.default_int_handler]


def test_local_backend_stops_on_a_ctrl_c_while_it_waits_on_its_worker():
    scenario = small_scenario(replicates=6)
    tasks = [ReplicateTask((0, r), scenario, r) for r in range(6)]
    # Half a second in, the backend is waiting on its worker (starting it alone takes longer).
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            for _ in LocalBackend(1).run(tasks):
                pass
    finally:
        timer.cancel()
    assert multiprocessing.active_children() == []  # the worker was stopped and joined
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
