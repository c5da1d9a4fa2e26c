"""Which points a sweep's next task carries: the order points go out in, and how many.

Dask costs a few milliseconds of CPU per task on each side whatever the task computes
(``./run bench --only sweep:task_cost``), and on a small machine that CPU comes out of the
points' own cores; so a sweep wants few tasks. It also wants the workers to finish together
(the last worker alone sets the wall time), tasks of at most about ``TASK_SECONDS`` (results
stream back, a lost worker loses little), and no knowledge of a point's cost in advance.

- **Order.** Points go out in a spread order (:func:`spread_order`): every run of consecutive
  points in it samples the whole sweep evenly, so the cost measured on the first points
  predicts the rest and two tasks of as many points cost about the same even when the cost
  drifts along a grid (the benchmarks' fold simulations cost a third more at one end of
  their gain grid than at the other). The table is in point order whatever the order of
  running (the journal holds rows as they finish), and a sweep stopped early has points
  from all over its range.
- **Size** (:meth:`BatchPlanner.size`), for a worker with a free slot (about two tasks per
  worker thread are in flight, so a worker never waits for the client between tasks):
  while no point's cost is known, one point for the first task of each worker thread (its
  time is the measurement) and ``BLIND_BATCH`` for the task queued behind it; then the
  worker's *share*: the remaining work (points not yet sent, plus the work in flight on every
  worker, from the measured mean cost) split over the worker threads, less what this worker
  has in flight. Once ``KNOWN_ENOUGH`` costs are measured and the spread of the point costs
  says that the whole share would end within ``MIN_TASK_SECONDS / 2`` of its estimate
  (``std * sqrt(n)`` for a share of ``n`` points of independent cost), and this worker's
  own mean cost is as close to everyone's as its noise allows (a slower machine would end
  late), the task takes the whole share; otherwise half of it (guided self-scheduling), so
  that later tasks correct the estimate. Never more than ``TASK_SECONDS`` of work or
  ``MAX_BATCH`` points, never less than ``MIN_TASK_SECONDS``: a share smaller than that (the
  last points) goes as one task to the worker that will be free first, queued behind its
  running task; the others get nothing more.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Final, TypeVar

import numpy as np

T = TypeVar("T")

#: Target wall time of one task [s]: long enough that Dask's cost per task is a few per cent,
#: short enough that results stream back and a lost worker loses little.
TASK_SECONDS: Final = 0.5
#: Least work of a task once the points' cost is known [s], and twice the imbalance at the
#: end that a task may risk (see the module docstring).
MIN_TASK_SECONDS: Final = 0.04
#: Most points in one task, however cheap.
MAX_BATCH: Final = 500
#: Points of the task queued behind each worker thread's one-point first task, sent before any
#: cost is known (the worker is not idle while the client sizes the next).
BLIND_BATCH: Final = 8
#: Measured point costs before their spread is trusted to size a whole share at once.
KNOWN_ENOUGH: Final = 8


def spread_order(items: Sequence[T]) -> list[T]:
    """``items`` in van der Corput order: positions sorted by their binary digits reversed
    (for ``n`` a power of two: 0, n/2, n/4, 3n/4, n/8, ...), so that every run of
    consecutive items of the result is spread evenly over the whole sequence."""
    bits = max(1, (len(items) - 1).bit_length())
    position = np.arange(len(items), dtype=np.int64)
    reversed_bits = np.zeros_like(position)
    for b in range(bits):
        reversed_bits |= ((position >> b) & 1) << (bits - 1 - b)
    return [items[i] for i in np.argsort(reversed_bits).tolist()]


@dataclass
class Costs:
    """Running count, mean and variance of the measured point costs [s] (Welford's update)."""

    n: int = 0
    mean: float = 0.0
    _m2: float = 0.0

    def add(self, values: Sequence[float]) -> None:
        for x in values:
            if math.isfinite(x):
                self.n += 1
                delta = x - self.mean
                self.mean += delta / self.n
                self._m2 += delta * (x - self.mean)

    @property
    def std(self) -> float:
        return math.sqrt(self._m2 / (self.n - 1)) if self.n > 1 else math.inf


@dataclass
class InFlight:
    """A task sent to a worker: its points, and when the client sent it [s, monotonic]."""

    points: int
    sent: float


@dataclass
class BatchPlanner:
    """The size of each next task (module docstring). ``batch``: a fixed size instead."""

    batch: int | None = None
    costs: Costs = field(default_factory=Costs)      # all measured point costs
    by_worker: dict[str, Costs] = field(default_factory=dict)
    blind: int = 0                                  # tasks sent before any cost was known

    def record(self, worker: str, run_times: Sequence[float]) -> None:
        """The measured costs [s] of the points of a task sent to ``worker``."""
        self.costs.add(run_times)
        self.by_worker.setdefault(worker, Costs()).add(run_times)

    def size(self, worker: str, threads: dict[str, int], flights: dict[str, list[InFlight]],
             finished: dict[str, float], remaining: int, now: float) -> int:
        """Points for the next task of ``worker`` (which has a free slot), given the worker
        threads of the cluster (``threads``: address -> threads), the tasks in flight on each
        worker (oldest first), when each worker last finished a task (client time), the points
        not yet sent and the time now [s, monotonic]. 0: send it nothing now (its share is
        less than the least task, it has work in flight, and another worker will be free
        sooner)."""
        if self.batch is not None:
            return min(self.batch, remaining)
        total_threads = max(1, sum(threads.values()))
        if self.costs.n == 0 or self.costs.mean <= 0:
            first = self.blind < total_threads
            self.blind += 1
            return 1 if first else min(BLIND_BATCH, max(1, math.ceil(remaining / (2 * total_threads))))
        m = self.costs.mean
        committed = {w: self._committed(w, threads.get(w, 1), flights.get(w, []), finished, now, m)
                     for w in set(threads) | set(flights)}
        work = remaining * m + sum(committed.values())
        share = (work * threads.get(worker, 1) / total_threads - committed.get(worker, 0.0)) / m
        least = max(1, math.ceil(MIN_TASK_SECONDS / m))
        most = max(1, min(MAX_BATCH, int(TASK_SECONDS / m)))
        if share < least:      # the last points: to the worker that will be free first, as one task
            load = {w: committed.get(w, 0.0) / n for w, n in threads.items()}
            if flights.get(worker) and load.get(worker, 0.0) > min(load.values(), default=0.0):
                return 0
            return min(least, remaining)
        size = math.ceil(share if self._whole_share_ends_on_time(worker, share) else share / 2)
        return max(1, min(max(least, min(most, size)), remaining))

    def _whole_share_ends_on_time(self, worker: str, share: float) -> bool:
        """Whether ``share`` points on ``worker`` would take their estimated time to within
        MIN_TASK_SECONDS / 2: the spread of independent point costs over the share
        (``std sqrt(share)``), plus, times the share, how much further this worker's mean cost
        is from everyone's than the noise of its own mean allows (two standard errors): a
        slower machine. Needs KNOWN_ENOUGH costs in all and on this worker."""
        mine = self.by_worker.get(worker)
        if self.costs.n < KNOWN_ENOUGH or mine is None or mine.n < KNOWN_ENOUGH:
            return False
        share = max(share, 1.0)
        slower = max(0.0, abs(mine.mean - self.costs.mean) - 2 * mine.std / math.sqrt(mine.n))
        return self.costs.std * math.sqrt(share) + slower * share <= MIN_TASK_SECONDS / 2

    @staticmethod
    def _committed(worker: str, threads: int, flights: list[InFlight], finished: dict[str, float],
                   now: float, mean: float) -> float:
        """Work [s] still to do in the tasks in flight on ``worker``: the ones running (the
        first ``threads``) since the worker last finished a task or since they were sent,
        whichever is later, less what they have run; the queued ones in full."""
        work = 0.0
        for i, task in enumerate(flights):
            left = task.points * mean
            if i < threads:
                left -= now - max(task.sent, finished.get(worker, -math.inf))
            work += max(0.0, left)
        return work
