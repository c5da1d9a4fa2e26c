"""wait_for_matches: the settle rule on scripted match counts (no DDS needed)."""

from __future__ import annotations

from tensegrity_ros.rclpy_utils import matching
from tensegrity_ros.rclpy_utils.matching import wait_for_matches


class ScriptedPublisher:
    """get_subscription_count() returns the scripted counts in turn, then the last one."""

    def __init__(self, counts):
        self.counts = list(counts)

    def get_subscription_count(self) -> int:
        return self.counts.pop(0) if len(self.counts) > 1 else self.counts[0]


class ScriptedClock:
    """The helper's clock, advanced only by its polls: what it sees is the same under any
    scheduling delay of the process (a real poll of 0.01 s may take 50 ms on a loaded machine)."""

    def __init__(self) -> None:
        self.now = 0.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def test_returns_only_after_the_matches_held_for_the_settle_time(monkeypatch):
    clock = ScriptedClock()
    monkeypatch.setattr(matching, "time", clock)
    pub = ScriptedPublisher([0, 0, 1, 1, 0, 1])      # a match that drops restarts the settle
    assert wait_for_matches([pub], 1, None, settle_s=0.05, poll=clock.sleep)
    # the match from the sixth poll (t = 0.05 s) on held 0.05 s: returned at t >= 0.10 s,
    # and the drop at the fifth poll was seen (the count's script was read to its end)
    assert clock.now >= 0.05 + 5 * 0.01 - 1e-12
    assert pub.counts == [1]


def test_every_publisher_must_reach_the_minimum():
    a, b = ScriptedPublisher([2]), ScriptedPublisher([1])
    assert not wait_for_matches([a, b], 2, 0.05, settle_s=0.0)
    assert wait_for_matches([a, b], 1, 0.05, settle_s=0.0)


def test_timeout_and_stop_return_false():
    assert not wait_for_matches([ScriptedPublisher([0])], 1, 0.03)
    assert not wait_for_matches([ScriptedPublisher([0])], 1, None, should_stop=lambda: True)
