"""DeferredSignals: a Ctrl-C or SIGTERM inside the block is handled when it ends (once), the
usual handlers come back."""

import signal
import threading

import pytest

from mjsuff.cli.signals import sigterm_interrupts
from mjsuff.experiment.deferred_signals import DeferredSignals

pytestmark = pytest.mark.usefixtures("usual_signal_handlers")


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
