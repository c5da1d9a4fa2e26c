"""Free-running play on the wall clock: when the next tick is due and how many whole steps
each tick makes. Plain logic, no node: the loop thread asks, passing the (steady) wall time.

A tick happens every ``1 / publish_rate`` seconds of wall time and makes the whole steps of
``step_ns`` due by then at ``real_time_factor`` simulated seconds per wall second, counted
from where the schedule (re)started; each tick with at least one step publishes once.
``real_time_factor = 0`` is as fast as possible, no wait: each tick makes the whole steps in
one publish period of simulated time (at least one), so the state is published at
``publish_rate`` per simulated second whatever the step.

Never a burst of catch-up steps: a tick more than ``max_lag`` seconds late restarts the
wall schedule from that moment, and a tick that would have to make more than ``max_lag``
seconds' worth of simulated time makes one step and restarts the step count from there
(the simulation clock slips behind the wall clock instead). :meth:`TickSchedule.restart`
(play after a pause, a reset, any work of the loop that is not a tick) starts both again:
the first tick after it makes one step's worth, never the steps a pause "missed".
"""

from __future__ import annotations

import math

#: Free-running catch-up limit [s of wall time]: a tick this late resynchronises instead of
#: bursting steps.
MAX_LAG = 0.25


class TickSchedule:
    """The tick schedule of free-running play (see the module docstring). Times are wall
    seconds of a steady clock; steps are counts of ``step_ns`` nanoseconds."""

    def __init__(self, publish_rate: float, real_time_factor: float, step_ns: int, max_lag: float = MAX_LAG):
        self.period = 1.0 / publish_rate
        self.real_time_factor = real_time_factor
        self.step_ns = step_ns
        self.max_lag = max_lag
        self._base: tuple[int, int] | None = None    # (step, tick) the step count runs from
        self._ticks = 0
        self._deadline: float | None = None           # wall time of the next tick

    def restart(self) -> None:
        """Start again at the next tick: its wall time and its steps count from there."""
        self._base = None
        self._deadline = None

    def steps_due(self, k: int) -> int:
        """At a tick, with the simulation at step ``k``: the step it should reach (``k``:
        nothing is due at this tick, nothing to publish)."""
        if self._base is None:
            self._base, self._ticks = (k, 0), 0
        self._ticks += 1
        if self.real_time_factor == 0:
            return k + max(1, math.floor(self.period * 1e9 / self.step_ns + 1e-9))
        base_k, base_tick = self._base
        sim_ns = (self._ticks - base_tick) * self.period * 1e9 * self.real_time_factor
        target = base_k + math.floor(sim_ns / self.step_ns + 1e-9)
        if (target - k) * self.step_ns > self.max_lag * self.real_time_factor * 1e9:
            self._base = (k + 1, self._ticks)         # fell behind: slip, do not burst
            return k + 1
        return target

    def wait(self, now: float) -> float:
        """After a tick that ended at wall time ``now``: seconds until the next tick (0: at once)."""
        if self.real_time_factor == 0:
            return 0.0
        self._deadline = (now if self._deadline is None else self._deadline) + self.period
        delay = self._deadline - now
        if delay < -self.max_lag:                     # far behind: resynchronise, do not burst
            self.restart()
            return 0.0
        return max(0.0, delay)
