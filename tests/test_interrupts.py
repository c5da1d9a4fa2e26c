"""Ctrl-C held back around a library call: delivered once the block ends, to the handler
that was in place, and only in the main thread. Real signals to this thread (``pthread_kill``),
as a terminal's Ctrl-C is. And a Ctrl-C that a library turned into an error of its own is
still found, so that it ends the work as a Ctrl-C."""

from __future__ import annotations

import signal
import threading

import pytest

from tensegrity_core.errors import interrupted
from tensegrity_core.interrupts import sigint_deferred

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


def pybind11_import_interrupted(*_args, **_kwargs):
    """What a pybind11 module (matplotlib's, MuJoCo's) raises when a Ctrl-C lands while it is
    imported: ``ImportError("initialization failed")`` from the ``KeyboardInterrupt``
    (pybind11's ``PYBIND11_MODULE``; seen as a sweep's "base cannot be computed" error)."""
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as ctrl_c:
        raise ImportError("initialization failed") from ctrl_c


def test_a_ctrl_c_is_found_through_causes_and_contexts():
    with pytest.raises(ImportError) as caught:
        pybind11_import_interrupted()
    assert interrupted(caught.value)
    try:
        try:
            pybind11_import_interrupted()
        except ImportError:
            raise ValueError("reworded") from None     # cause suppressed: the context still holds it
    except ValueError as err:
        assert interrupted(err)
    assert not interrupted(ValueError("a plain failure")) and not interrupted(None)
    assert interrupted(KeyboardInterrupt())


def test_any_command_whose_error_comes_from_a_ctrl_c_exits_as_interrupted(capsys):
    """The command line's net for every command: an error whose chain holds a Ctrl-C ends
    with exit code 130 and says nothing more (the error's text would blame the input)."""
    import argparse

    from tensegrity_ros.cli import _run
    from tensegrity_ros.cli._common import CliError

    def command(_args):
        try:
            pybind11_import_interrupted()
        except ImportError as err:
            raise CliError(f"cannot load the plugin: {err}") from None

    def failing(_args):
        raise CliError("cannot load the plugin: no such file")

    assert _run(argparse.Namespace(func=command, ros_args=[])) == 130
    assert capsys.readouterr().err == ""
    assert _run(argparse.Namespace(func=failing, ros_args=[])) == 2
    assert capsys.readouterr().err.strip() == "error: cannot load the plugin: no such file"


def test_with_sigterm_a_sigterm_taken_as_ctrl_c_is_held_too():
    """The ROS client commands take SIGTERM as Ctrl-C (``KeyboardInterrupt``)."""
    previous = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        reached = []
        with pytest.raises(KeyboardInterrupt):
            with sigint_deferred(sigterm=True):
                signal.pthread_kill(threading.get_ident(), signal.SIGTERM)
                reached.append("after the signal")
        assert reached == ["after the signal"]
        assert signal.getsignal(signal.SIGTERM) is signal.default_int_handler
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGTERM, previous)
