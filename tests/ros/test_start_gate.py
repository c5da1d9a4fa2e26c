"""`tensegrity up`'s start gates (tensegrity_ros/apps/start_gate.py): a launched child
holds after its imports until the launcher's look at the graph is done; a closed gate ends
it with code 0 before it did anything, an opened one lets it go on. Plain Python children
(no ROS): about 0.5 s of CPU for the module."""

from __future__ import annotations

import io
import sys

import pytest

from tensegrity_ros.apps.launch import Launcher, ProcessSpec

#: A child that says it reached its gate, passes it, and says so.
CHILD = ("from tensegrity_ros.apps.start_gate import pass_gate; print('at the gate', flush=True); "
         "pass_gate(); print('through the gate', flush=True)")


def _children(n: int) -> tuple[Launcher, io.StringIO]:
    out = io.StringIO()
    specs = [ProcessSpec(f"c{i}", [sys.executable, "-c", CHILD]) for i in range(n)]
    return Launcher(specs, out=out), out


def test_a_closed_gate_ends_each_child_with_code_0_before_it_goes_on():
    launcher, out = _children(2)
    launcher.start(gated=True)
    launcher.close_gates()
    assert launcher.wait() == 0, out.getvalue()
    assert "through the gate" not in out.getvalue()
    assert out.getvalue().count("exited with code 0") == 2 and "ended by" not in out.getvalue(), out.getvalue()


def test_an_opened_gate_lets_each_child_go_on():
    launcher, out = _children(2)
    launcher.start(gated=True)
    launcher.open_gates()
    assert launcher.wait() == 0, out.getvalue()
    said = out.getvalue()
    assert said.count("] through the gate") == 2, said


def test_a_refusing_look_keeps_every_child_from_starting_and_propagates():
    class Refused(Exception):
        pass

    def look() -> None:
        raise Refused("a suite runs here")

    launcher, out = _children(2)
    with pytest.raises(Refused):
        launcher.run(look)
    assert all(p.returncode == 0 for p in launcher.procs.values()), out.getvalue()
    assert "through the gate" not in out.getvalue()


def test_a_child_without_a_gate_goes_on_at_once():
    launcher, out = _children(1)
    launcher.start()
    assert launcher.wait() == 0
    assert "[c0] through the gate" in out.getvalue()
