"""The order points go out in and the size of each task (tensegrity_core/sweep/scheduling.py).

Costs here are multiples of m = 1/256 s, exact in binary, so every share below is an exact
integer: least task = ceil(0.04 s / m) = 11 points, most = 0.5 s / m = 128 points."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.sweep.scheduling import (
    BLIND_BATCH,
    KNOWN_ENOUGH,
    MAX_BATCH,
    BatchPlanner,
    Costs,
    InFlight,
    spread_order,
)

M = 1 / 256
TWO = {"A": 1, "B": 1}                # two workers of one thread each


def planner(costs_a: list[float], costs_b: list[float] | None = None) -> BatchPlanner:
    p = BatchPlanner()
    p.record("A", costs_a)
    p.record("B", costs_a if costs_b is None else costs_b)
    return p


def test_spread_order_of_a_power_of_two_puts_every_aligned_block_evenly_over_the_whole():
    """Bit reversal: block k of 2**i consecutive items of the result is one residue class mod
    n / 2**i of the positions, so its items are evenly spaced across the whole sequence."""
    n = 64
    out = spread_order(list(range(n)))
    assert out[:8] == [0, 32, 16, 48, 8, 40, 24, 56]
    for size in (2, 4, 8, 16, 32):
        for k in range(0, n, size):
            block = sorted(out[k:k + size])
            assert {b - a for a, b in zip(block, block[1:])} == {n // size}


@given(st.lists(st.integers(), max_size=300))
def test_spread_order_is_a_permutation(items):
    out = spread_order(items)
    assert sorted(out) == sorted(items) and len(out) == len(items)


def test_spread_order_of_a_cost_that_drifts_along_the_grid_gives_halves_of_equal_cost():
    """Costs rising linearly from 1 to 2 along 200 points (a drift along a grid): the contiguous
    halves cost 1.25 and 1.75 a point on average (ratio 1.4); the halves of the spread order
    within 1 % of each other, its quarters within 2 %."""
    cost = [1.0 + i / 199 for i in range(200)]
    out = spread_order(cost)
    assert math.isclose(sum(cost[100:]) / sum(cost[:100]), 1.4, rel_tol=0.01)
    assert math.isclose(sum(out[:100]), sum(out[100:]), rel_tol=0.01)
    quarters = [sum(out[k:k + 50]) for k in range(0, 200, 50)]
    assert max(quarters) / min(quarters) < 1.02


def test_costs_mean_and_sample_std_match_the_textbook_formulas():
    c = Costs()
    c.add([1.0, 2.0, 4.0, math.nan])                  # a NaN (a point without a time) is skipped
    assert c.n == 3 and math.isclose(c.mean, 7 / 3)
    assert math.isclose(c.std, math.sqrt(((1 - 7 / 3) ** 2 + (2 - 7 / 3) ** 2 + (4 - 7 / 3) ** 2) / 2))
    assert Costs().std == math.inf


def test_before_any_cost_one_point_per_worker_thread_then_a_blind_batch():
    p = BatchPlanner()
    assert [p.size("A", TWO, {}, {}, 1000, 0.0) for _ in range(4)] == [1, 1, BLIND_BATCH, BLIND_BATCH]
    assert p.size("A", TWO, {}, {}, 12, 0.0) == 3                     # few left: 12 / (2 x 2)


def test_alike_points_take_the_workers_whole_share_at_once():
    """Nothing in flight, 128 points left of m each: 64 m of work per worker, 64 points."""
    p = planner([M] * KNOWN_ENOUGH)
    assert p.size("A", TWO, {}, {}, 128, 0.0) == 64


def test_widely_spread_costs_take_half_the_share():
    """Costs 0 and 2m alternating, 10 on each worker: the sample std of the 20 is
    m sqrt(20/19) = 4.0 ms, and over 64 points std sqrt(64) = 32 ms > 20 ms: half the share."""
    p = planner([0.0, 2 * M] * 5)
    assert math.isclose(p.costs.std, M * math.sqrt(20 / 19))
    assert p.size("A", TWO, {}, {}, 128, 0.0) == 32


def test_a_worker_slower_than_the_others_takes_half_its_share():
    """A's points take 1.25 m, B's 0.75 m (mean m): 0.25 m x 64 points = 62 ms off > 20 ms."""
    p = planner([1.25 * M] * KNOWN_ENOUGH, [0.75 * M] * KNOWN_ENOUGH)
    assert p.size("A", TWO, {}, {}, 128, 0.0) == 32
    assert p.size("B", TWO, {}, {}, 128, 0.0) == 32


def test_too_few_costs_known_take_half_the_share():
    p = planner([M] * (KNOWN_ENOUGH - 1))
    assert p.size("A", TWO, {}, {}, 128, 0.0) == 32


def test_the_work_in_flight_counts_against_the_worker_that_has_it():
    """A runs 4 points just started and has 32 queued: 36 m in flight; 92 points left:
    (92 + 36) / 2 = 64 points each, A's share 64 - 36 = 28, B's 64."""
    p = planner([M] * KNOWN_ENOUGH)
    flights = {"A": [InFlight(4, 0.0), InFlight(32, 0.0)]}
    assert p.size("A", TWO, flights, {}, 92, 0.0) == 28
    assert p.size("B", TWO, flights, {}, 92, 0.0) == 64


def test_a_running_task_counts_only_what_is_left_of_it():
    """A's 40-point task started when its previous one finished, 10 m ago: 30 m left; with 98
    points to send, (98 + 30) / 2 = 64 each, A's share 34."""
    p = planner([M] * KNOWN_ENOUGH)
    now = 5.0
    flights = {"A": [InFlight(40, 1.0)]}              # sent long before it could start
    assert p.size("A", TWO, flights, {"A": now - 10 * M}, 98, now) == 34


def test_a_worker_whose_share_is_in_flight_gets_nothing_now_and_the_others_the_rest():
    p = planner([M] * KNOWN_ENOUGH)
    flights = {"A": [InFlight(60, 0.0)]}
    assert p.size("A", TWO, flights, {}, 4, 0.0) == 0                 # (4 + 60) / 2 - 60 < 0
    assert p.size("B", TWO, flights, {}, 4, 0.0) == 4                 # share 32, 4 left


def test_the_last_points_go_to_the_worker_free_first_queued_behind_its_running_task():
    """A runs 20 points, B 30, 5 left: (5 + 50) / 2 = 27.5 points each, so A's share is 7.5,
    under the least task (11): A will be free first and takes the 5 now; B nothing."""
    p = planner([M] * KNOWN_ENOUGH)
    flights = {"A": [InFlight(20, 0.0)], "B": [InFlight(30, 0.0)]}
    assert p.size("A", TWO, flights, {}, 5, 0.0) == 5
    assert p.size("B", TWO, flights, {}, 5, 0.0) == 0


def test_tasks_never_take_less_than_the_least_work_nor_more_than_the_cap():
    p = planner([M] * KNOWN_ENOUGH)
    assert p.size("A", TWO, {}, {}, 12, 0.0) == 11                    # share 6 < 11 = ceil(0.04 s / m)
    assert p.size("A", TWO, {}, {}, 1000, 0.0) == 128                 # share 500 > 0.5 s / m
    fast = planner([0.001] * KNOWN_ENOUGH)
    assert fast.size("A", TWO, {}, {}, 10**6, 0.0) == MAX_BATCH
    slow = planner([2.0] * KNOWN_ENOUGH)
    assert slow.size("A", TWO, {}, {}, 1000, 0.0) == 1                # 2 s points: one a task


def test_a_worker_of_two_threads_gets_two_shares():
    """Threads A: 2, B: 1; 120 points: 40 a thread, 80 for A."""
    p = planner([M] * KNOWN_ENOUGH)
    assert p.size("A", {"A": 2, "B": 1}, {}, {}, 120, 0.0) == 80


def test_a_fixed_batch_is_that_size_whatever_is_known():
    p = BatchPlanner(batch=7)
    assert p.size("A", TWO, {}, {}, 100, 0.0) == 7 and p.size("A", TWO, {}, {}, 5, 0.0) == 5


@given(remaining=st.integers(1, 5000), cost=st.floats(1e-5, 30.0), spread=st.floats(0.0, 2.0),
       a=st.lists(st.integers(1, 400), max_size=3), b=st.lists(st.integers(1, 400), max_size=3),
       elapsed=st.floats(0.0, 100.0))
def test_a_task_is_never_empty_nor_larger_than_what_is_left_and_an_idle_worker_always_gets_one(
        remaining, cost, spread, a, b, elapsed):
    """Whatever is measured and in flight: 1 .. remaining points, or 0 only for a worker that
    has work in flight (so a sweep never stalls with points left and nothing running)."""
    p = planner([cost * (1 + spread), cost * max(0.0, 1 - spread)] * KNOWN_ENOUGH)
    flights = {"A": [InFlight(n, 0.0) for n in a], "B": [InFlight(n, 0.0) for n in b]}
    for worker in TWO:
        got = p.size(worker, TWO, flights, {}, remaining, elapsed)
        assert 0 <= got <= remaining
        assert got > 0 or flights[worker]
