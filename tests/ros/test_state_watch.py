"""The controllers' state watch without a node or DDS, on an injected wall clock: silence is
the wall time of regular looks, and a stall of the watcher (no look for a while) counts at
most two look periods."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_ros.nodes.state_watch import StateWatch

pytestmark = pytest.mark.ros

P = 0.05


def test_regular_looks_count_wall_time_from_the_last_state_heard():
    w = StateWatch(P)
    w.heard(10.0)
    assert w.look(10.03) == pytest.approx(0.03)          # from the state, not from an earlier look
    for k in range(2, 21):
        silence = w.look(10.0 + 0.05 * k)
    assert silence == pytest.approx(1.0)
    w.heard(11.01)
    assert w.look(11.05) == pytest.approx(0.04)


def test_a_stalled_watcher_counts_two_periods_for_its_stall():
    w = StateWatch(P)
    w.heard(0.0)
    w.look(0.05)
    assert w.look(3.05) == pytest.approx(0.05 + 2 * P)   # stopped 3 s: 0.1 s of it counted
    assert w.look(3.10) == pytest.approx(0.05 + 3 * P)   # then wall time again


def test_the_first_look_without_a_state_heard_counts_nothing():
    assert StateWatch(P).look(5.0) == 0.0


@given(st.lists(st.floats(0.0, 5.0), min_size=1, max_size=50))
def test_silence_is_the_looked_time_each_gap_capped_at_two_periods(gaps):
    w, now = StateWatch(P), 0.0
    w.heard(now)
    for gap in gaps:
        now += gap
        silence = w.look(now)
    assert silence == pytest.approx(sum(min(g, 2 * P) for g in gaps))
    assert silence <= now + 1e-12                        # never more than wall time
