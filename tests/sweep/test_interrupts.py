"""Ctrl-C held back around a blocking call: delivered once the block ends, to the handler
that was in place, and only in the main thread. Real signals to this thread (``pthread_kill``),
as a terminal's Ctrl-C is."""

from __future__ import annotations

import signal
import threading

import pytest

from tensegrity_core.sweep.interrupts import sigint_deferred

pytestmark = pytest.mark.skipif(threading.current_thread() is not threading.main_thread(),
                                reason="signal handlers are set from the main thread only")


def ctrl_c() -> None:
    """SIGINT to this thread; its Python handler runs before the next line of this thread."""
    signal.pthread_kill(threading.get_ident(), signal.SIGINT)


def test_a_ctrl_c_in_the_block_is_raised_where_the_block_ends():
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with sigint_deferred():
            ctrl_c()
            reached.append("after the signal")      # the block goes on to its end
        reached.append("after the block")
    assert reached == ["after the signal"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_block_without_ctrl_c_changes_nothing():
    with sigint_deferred():
        value = 42
    assert value == 42 and signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_the_held_ctrl_c_goes_to_the_handler_in_place_and_an_ignored_one_stays_ignored():
    got: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: got.append(signum))
    try:
        with sigint_deferred():
            ctrl_c()
            assert got == []
        assert got == [signal.SIGINT]
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        with sigint_deferred():
            ctrl_c()
        assert got == [signal.SIGINT] and signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_an_error_of_the_block_goes_on_and_the_handler_is_restored():
    with pytest.raises(ValueError, match="the block's own"):
        with sigint_deferred():
            raise ValueError("the block's own")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_outside_the_main_thread_nothing_changes():
    seen = []

    def run():
        with sigint_deferred():
            seen.append(signal.getsignal(signal.SIGINT))

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    assert seen == [signal.default_int_handler]
