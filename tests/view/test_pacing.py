"""The view's pacing (tensegrity_ros/view/pacing.py) on made-up times: no clock, no threads."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_ros.view.pacing import Pacer


@given(period=st.floats(1e-3, 1.0), late=st.lists(st.floats(0.0, 0.999), min_size=1, max_size=200))
def test_wake_ups_late_by_less_than_a_period_keep_the_rate(period, late):
    """Each tick starts ``late[k]`` periods after its deadline: the k-th deadline is still
    ``t0 + k period`` (a thread waiting a period from each start would be ``sum(late)`` behind)."""
    pacer, t0 = Pacer(period), 100.0
    deadline = pacer.tick(t0)
    for k, fraction in enumerate(late, start=1):
        assert deadline == pytest.approx(t0 + k * period, rel=1e-12, abs=1e-9)
        deadline = pacer.tick(deadline + fraction * period)


def test_a_tick_a_period_late_or_more_restarts_the_grid_without_a_burst():
    pacer = Pacer(0.1)
    assert pacer.tick(0.0) == pytest.approx(0.1)
    assert pacer.tick(0.35) == pytest.approx(0.45)      # 0.25 s late: the next one a period on, not at 0.2
    assert pacer.tick(0.45) == pytest.approx(0.55)


def test_an_early_tick_keeps_its_deadline():
    """A thread woken on purpose (Play, a seek) before its deadline ticks again at that deadline."""
    pacer = Pacer(0.1)
    assert pacer.tick(0.0) == pytest.approx(0.1)
    assert pacer.tick(0.04) == pytest.approx(0.1)
    assert pacer.tick(0.1) == pytest.approx(0.2)


@pytest.mark.parametrize("period", [0.0, -1.0, float("nan")])
def test_a_period_that_is_not_positive_is_refused(period):
    with pytest.raises(ValueError, match="period must be > 0 s"):
        Pacer(period)
