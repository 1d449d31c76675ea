"""DeferredSignals: a Ctrl-C or SIGTERM is handled where the caller says, never in between (a
second one at once), and the usual handlers come back."""

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
    SIGTERM's default action (earlier tests in this process may have left a handler)."""
    previous = {
        signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
        signal.SIGTERM: signal.signal(signal.SIGTERM, signal.SIG_DFL),
    }
    yield
    for signum, handler in previous.items():
        signal.signal(signum, handler)


def test_a_signal_waits_for_deliver():
    with DeferredSignals() as signals:
        signal.raise_signal(signal.SIGINT)  # handled on return: recorded, nothing raised
        assert signals.pending
        with pytest.raises(KeyboardInterrupt):
            signals.deliver()
        assert not signals.pending
        signals.deliver()  # nothing left to hand on
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_second_signal_is_handled_at_once():
    with DeferredSignals() as signals:
        signal.raise_signal(signal.SIGINT)
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
        assert not signals.pending


def test_a_pending_signal_is_delivered_on_exit_unless_an_error_is_going_up():
    with pytest.raises(KeyboardInterrupt):
        with DeferredSignals():
            signal.raise_signal(signal.SIGINT)
    with pytest.raises(ValueError):  # the error going up is the one reported
        with DeferredSignals():
            signal.raise_signal(signal.SIGINT)
            raise ValueError("stopping anyway")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_sigterm_is_deferred_only_where_it_interrupts():
    with sigterm_interrupts(), DeferredSignals() as signals:
        signal.raise_signal(signal.SIGTERM)
        assert signals.pending
        with pytest.raises(KeyboardInterrupt):
            signals.deliver()
    # Elsewhere SIGTERM keeps its default action (to end the process), untouched.
    with DeferredSignals():
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_outside_the_main_thread_nothing_changes():
    seen = []

    def body():
        with DeferredSignals() as signals:
            seen.append((signal.getsignal(signal.SIGINT), signals.pending))

    thread = threading.Thread(target=body)
    thread.start()
    thread.join()
    assert seen == [(signal.default_int_handler, False)]


def test_local_backend_takes_a_ctrl_c_between_replicates_not_while_the_caller_writes_one():
    scenario = small_scenario(replicates=3)
    tasks = [ReplicateTask((0, r), scenario, r) for r in range(3)]
    results = LocalBackend(1).run(tasks)
    first, _ = next(results)
    assert first.replicate == 0
    # The caller is saving replicate 0 when Ctrl-C comes: it finishes that undisturbed ...
    signal.raise_signal(signal.SIGINT)
    # ... and the interrupt comes out of the backend, which stops its worker.
    with pytest.raises(KeyboardInterrupt):
        next(results)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
