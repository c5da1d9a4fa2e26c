"""How long a controller has watched for a new state and seen none: the silence its state
watchdog judges. Plain logic, no node: the node passes the (steady) wall time.

A watchdog that compares wall time with the last state's arrival blames the simulator for
time the controller itself did not run: a controller short of CPU (a loaded machine, a
stopped process) comes back to a due timer, and rclpy's executor runs a due timer before a
subscription whose state is waiting. So the silence counts only the controller's looks: each
look adds the time since the previous look, or since the last state heard if that came later,
but at most ``2 * period`` [s], ``period`` being how often the node looks. A controller that
runs looks every ``period`` and counts wall time; one that did not run for a while counts at
most two periods for that while. The node takes a state waiting in its reader before a look
(:func:`~tensegrity_ros.rclpy_utils.raw_take.take_waiting`), so a state that came is heard
first.
"""

from __future__ import annotations

#: How often a controller's state watchdog looks [s].
WATCH_PERIOD = 0.05


class StateWatch:
    """The silence [s of looks] since the last state heard (or the watch's start)."""

    def __init__(self, period: float) -> None:
        self.period = period
        self.silence = 0.0
        self._heard_at: float | None = None     # wall time of the last state heard (or start)
        self._looked_at: float | None = None    # wall time of the last look

    def heard(self, now: float) -> None:
        """A new state at wall time ``now`` [s] (or a new start of the watch): no silence."""
        self.silence, self._heard_at = 0.0, now

    def look(self, now: float) -> float:
        """A look at wall time ``now`` [s] that saw no new state: the silence so far [s]."""
        since = max((t for t in (self._looked_at, self._heard_at) if t is not None), default=now)
        self._looked_at = now
        self.silence += min(max(0.0, now - since), 2.0 * self.period)
        return self.silence
