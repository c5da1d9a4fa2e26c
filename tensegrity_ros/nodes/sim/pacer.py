"""Paced lockstep play: the wall time at which a stepped state may be published. Plain logic,
no node.

In lockstep a step waits for its command; with ``lockstep_real_time_factor`` > 0 the state a
step reaches is also published no sooner than that factor allows, counted from where
playing began (:meth:`LockstepPacer.restart`): the state of step ``k`` is due
``(k - k0) * step_size / factor`` wall seconds after the anchor ``(wall0, k0)``. The pacer
only delays; it never hurries. A controller that fell more than ``max_lag`` seconds behind
the schedule moves the anchor to now (the clock slips, it never catches up).
"""

from __future__ import annotations

from tensegrity_ros.nodes.sim.schedule import MAX_LAG


class LockstepPacer:
    """When a lockstep state is due (see the module docstring); ``real_time_factor = 0``:
    unpaced, every state is due at once."""

    def __init__(self, real_time_factor: float, step_size: float, max_lag: float = MAX_LAG):
        self.real_time_factor = real_time_factor
        self.step_size = step_size
        self.max_lag = max_lag
        self._anchor: tuple[float, int] | None = None      # (wall time, step) of the schedule

    @property
    def paced(self) -> bool:
        return self.real_time_factor > 0

    def restart(self) -> None:
        """Anchor the schedule at the next state due (playing begins again)."""
        self._anchor = None

    def due(self, now: float, k: int) -> float | None:
        """The wall time at which the state just stepped to (step ``k``) is due, or None to
        publish it now (unpaced, already due, or the controller fell behind)."""
        if not self.paced:
            return None
        if self._anchor is None:
            self._anchor = (now, k - 1)
        wall0, k0 = self._anchor
        due = wall0 + (k - k0) * self.step_size / self.real_time_factor
        if due < now - self.max_lag:
            self._anchor = (now, k)
            return None
        return due if due > now else None
