"""When a stopping node gives up waiting for its subscribers' acknowledgements
(rclpy_utils/delivery.py), over a scripted clock: publishers whose readers acknowledge
everything at given times, or never. No DDS: the wait's decisions alone."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_ros.rclpy_utils.delivery import LIMIT_S, SLICE_S, STALL_S, wait_for_delivery

pytestmark = pytest.mark.ros


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class ScriptedPublisher:
    """A publisher whose readers have acknowledged all at ``acked_at`` [s] (inf: never); a
    reader leaves at ``leaves_at`` (what it owed is then owed to nobody)."""

    def __init__(self, clock: Clock, topic: str, acked_at: float, readers: int = 1,
                 leaves_at: float = math.inf) -> None:
        self.clock, self.topic_name, self.acked_at = clock, topic, acked_at
        self.readers, self.leaves_at = readers, leaves_at

    def get_subscription_count(self) -> int:
        return self.readers - (self.clock.now >= self.leaves_at)

    def wait_for_all_acked(self, timeout) -> bool:       # rclpy's: blocks until acked or timeout
        done_at = min(self.acked_at, self.leaves_at if self.readers == 1 else math.inf)
        end = self.clock.now + max(timeout.nanoseconds / 1e9, 1e-9)    # a real wait takes time
        self.clock.now = max(self.clock.now, min(done_at, end))
        return self.clock.now >= done_at


def _wait(clock: Clock, *acked_at: float) -> tuple[list[str], str]:
    pubs = [ScriptedPublisher(clock, f"t{i}", at) for i, at in enumerate(acked_at)]
    return wait_for_delivery(pubs, clock=clock)


def test_everything_acknowledged_already_costs_no_wait():
    clock = Clock()
    assert _wait(clock, 0.0, 0.0) == ([], "all acknowledged (0.00 s)")
    assert clock.now == 0.0


def test_a_starved_live_reader_is_waited_for_beyond_3_s_while_its_topics_keep_completing():
    clock = Clock()
    late, why = _wait(clock, 0.04, 2.9, 5.5, 6.8)        # each within STALL_S of the one before
    assert late == [] and why.startswith("all acknowledged")
    assert clock.now == pytest.approx(6.8, abs=1e-6)


def test_a_dead_reader_costs_the_stall_bound_and_is_named():
    clock = Clock()
    late, why = _wait(clock, 0.01, math.inf)
    assert late == ["t1"]
    assert why == f"no acknowledgement for {STALL_S:g} s ({clock.now:.2f} s)"
    assert clock.now == pytest.approx(0.01 + STALL_S, abs=1e-6)


def test_progress_never_holds_the_stop_beyond_the_limit():
    clock = Clock()
    late, why = _wait(clock, *(1.0 + 2.0 * i for i in range(6)))
    assert late == ["t4", "t5"] and why.startswith(f"still acknowledging after {LIMIT_S:g} s")
    assert clock.now == pytest.approx(LIMIT_S, abs=1e-6)


def test_a_reader_that_leaves_is_progress():
    clock = Clock()
    leaving = ScriptedPublisher(clock, "a", math.inf, readers=2, leaves_at=1.0)
    gone = ScriptedPublisher(clock, "b", math.inf, readers=1, leaves_at=2.5)
    late, _ = wait_for_delivery([leaving, gone], clock=clock)
    assert late == ["a"]                                 # its other reader never answers
    assert clock.now == pytest.approx(2.5 + STALL_S, abs=1e-6)     # progress at 1 s and at 2.5 s


@given(st.lists(st.one_of(st.floats(0.0, 12.0), st.just(math.inf)), min_size=1, max_size=6))
def test_the_wait_stops_at_once_when_all_is_acknowledged_and_never_later_than_the_limit(acked_at):
    clock = Clock()
    late, _ = _wait(clock, *acked_at)
    assert clock.now <= LIMIT_S + 1e-6
    done = sorted(a for a in acked_at if a <= clock.now)
    assert late == [f"t{i}" for i, a in enumerate(acked_at) if a > clock.now]
    if not late:
        assert clock.now == pytest.approx(max(acked_at), abs=1e-6)          # not a slice longer
    else:                                          # it gave up: at the limit or after a stall
        gaps = [b - a for a, b in zip([0.0, *done], [*done, clock.now])]
        assert clock.now >= LIMIT_S - 1e-6 or gaps[-1] >= STALL_S - 1e-6
        assert all(gap < STALL_S + SLICE_S for gap in gaps[:-1])
