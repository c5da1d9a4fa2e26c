"""The launcher's stop policy (tensegrity_ros.apps.stop_order) over simulated children on a
simulated clock: the recorder is signalled only after every other child has exited, each
stage escalates SIGINT -> SIGTERM -> SIGKILL within its bounds, and a child that never exits
delays the recorder by at most its stage's bound."""

from __future__ import annotations

import signal

import pytest

from tensegrity_ros.apps.stop_order import KILL_S, TERM_S, stop_bound_s, stop_in_stages, stop_stages

GRACE = 5.0
ESCALATION = [signal.SIGINT, signal.SIGTERM, signal.SIGKILL]


class Children:
    """Simulated children: ``exits[name] = (signal it obeys, seconds it then takes)``; a
    name missing from ``exits`` never exits. Records (time, event) on a simulated clock."""

    def __init__(self, exits: dict[str, tuple[signal.Signals, float]]) -> None:
        self.exits = exits
        self.now = 0.0
        self.exit_at: dict[str, float] = {}
        self.events: list[tuple[float, str, str]] = []

    def send(self, name: str, sig: signal.Signals) -> None:
        assert self.exit_at.get(name, float("inf")) > self.now, f"{name} signalled after it exited"
        self.events.append((self.now, name, sig.name))
        obeys = self.exits.get(name)
        if obeys is not None and ESCALATION.index(sig) >= ESCALATION.index(obeys[0]) and name not in self.exit_at:
            self.exit_at[name] = self.now + obeys[1]

    def wait(self, names: list[str], timeout_s: float) -> list[str]:
        ends = [self.exit_at.get(n, float("inf")) for n in names]
        self.now = min(self.now + timeout_s, max(max(ends), self.now))
        for n in names:
            if self.exit_at.get(n, float("inf")) <= self.now:
                self.events.append((self.exit_at[n], n, "exit"))
        return [n for n in names if self.exit_at.get(n, float("inf")) > self.now]

    def first(self, name: str, event: str) -> float:
        return min(t for t, n, e in self.events if n == name and e == event)


NAMES = ["sim", "ik", "controller", "formfind", "record"]


def test_stages_put_the_recorder_last_and_drop_empty_ones():
    assert stop_stages(NAMES, {"record"}) == [["sim", "ik", "controller", "formfind"], ["record"]]
    assert stop_stages(NAMES[:4], {"record"}) == [NAMES[:4]]
    assert stop_stages(["record"], {"record"}) == [["record"]]


def test_the_recorder_is_signalled_only_after_every_other_child_exited():
    # SIGINT takes 0.1 .. 1.5 s per child (sim's delivery wait the longest); SIGTERM for formfind
    kids = Children({"sim": (signal.SIGINT, 1.5), "ik": (signal.SIGINT, 0.1), "controller": (signal.SIGINT, 0.3),
                     "formfind": (signal.SIGTERM, 0.2), "record": (signal.SIGINT, 0.4)})
    done = []
    stop_in_stages(stop_stages(NAMES, {"record"}), GRACE, kids.send, kids.wait,
                   lambda stage, running: done.append((stage, running)))
    last_exit = max(kids.first(n, "exit") for n in NAMES[:4])
    assert kids.first("record", "SIGINT") >= last_exit
    assert [e for _, n, e in kids.events if n == "record"] == ["SIGINT", "exit"]     # never escalated
    # formfind ignored SIGINT: SIGTERM after the grace; nobody got SIGKILL
    assert kids.first("formfind", "SIGTERM") == pytest.approx(GRACE)
    assert not any(e == "SIGKILL" for _, _, e in kids.events)
    assert done == [(NAMES[:4], []), (["record"], [])]
    assert kids.now == pytest.approx(GRACE + 0.2 + 0.4)


def test_a_child_that_never_exits_delays_the_recorder_by_its_stage_bound_only():
    kids = Children({"ik": (signal.SIGINT, 0.1), "record": (signal.SIGINT, 0.4)})     # sim never exits
    done = []
    stop_in_stages(stop_stages(["sim", "ik", "record"], {"record"}), GRACE, kids.send, kids.wait,
                   lambda stage, running: done.append((stage, running)))
    assert [e for _, n, e in kids.events if n == "sim"] == ["SIGINT", "SIGTERM", "SIGKILL"]
    assert kids.first("sim", "SIGTERM") == pytest.approx(GRACE)
    assert kids.first("sim", "SIGKILL") == pytest.approx(GRACE + TERM_S)
    assert kids.first("record", "SIGINT") == pytest.approx(GRACE + TERM_S + KILL_S)
    assert done == [(["sim", "ik"], ["sim"]), (["record"], [])]
    assert kids.now <= stop_bound_s(2, GRACE)


def test_the_bound_is_every_stage_escalated_to_the_end():
    kids = Children({})                                  # nothing ever exits
    stop_in_stages(stop_stages(NAMES, {"record"}), GRACE, kids.send, kids.wait)
    assert kids.now == pytest.approx(stop_bound_s(2, GRACE)) == pytest.approx(2 * (GRACE + TERM_S + KILL_S))
    assert [e for _, n, e in kids.events if n == "record"] == ["SIGINT", "SIGTERM", "SIGKILL"]
