"""wait_for_matches: the settle rule on scripted match counts (no DDS needed)."""

from __future__ import annotations

import time

from tensegrity_ros.rclpy_utils.matching import wait_for_matches


class ScriptedPublisher:
    """get_subscription_count() returns the scripted counts in turn, then the last one."""

    def __init__(self, counts):
        self.counts = list(counts)

    def get_subscription_count(self) -> int:
        return self.counts.pop(0) if len(self.counts) > 1 else self.counts[0]


def test_returns_only_after_the_matches_held_for_the_settle_time():
    pub = ScriptedPublisher([0, 0, 1, 1, 0, 1])      # a match that drops restarts the settle
    start = time.monotonic()
    assert wait_for_matches([pub], 1, None, settle_s=0.05, poll=time.sleep)
    assert time.monotonic() - start >= 0.05 + 4 * 0.01
    assert pub.counts == [1]


def test_every_publisher_must_reach_the_minimum():
    a, b = ScriptedPublisher([2]), ScriptedPublisher([1])
    assert not wait_for_matches([a, b], 2, 0.05, settle_s=0.0)
    assert wait_for_matches([a, b], 1, 0.05, settle_s=0.0)


def test_timeout_and_stop_return_false():
    assert not wait_for_matches([ScriptedPublisher([0])], 1, 0.03)
    assert not wait_for_matches([ScriptedPublisher([0])], 1, None, should_stop=lambda: True)
