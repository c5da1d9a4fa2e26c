"""Refusal warnings throttled per reason: the same reason at most once a period, a new
reason at once (a node's one throttle per call site would hide a different refusal that
follows within the period, e.g. ActuatorForces sent to a robot right after a bad CableCommand).

Free of rclpy: the node asks :meth:`ReasonThrottle.admit` and logs unthrottled when told to.
"""

from __future__ import annotations

import traceback
from collections.abc import Hashable


class ReasonThrottle:
    """At most one admission per reason per ``period_s`` seconds [s, on the caller's clock]."""

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self._last: dict[Hashable, float] = {}

    def admit(self, reason: Hashable, now_s: float) -> bool:
        """Whether a warning for ``reason`` at time ``now_s`` [s] is shown (and if so, it
        starts this reason's period)."""
        last = self._last.get(reason)
        if last is not None and now_s - last < self.period_s:
            return False
        self._last[reason] = now_s
        return True


def reason_of(err: BaseException) -> tuple[str, str, int]:
    """The reason of a refusal: its type and the place that raised it (file, line). Each
    ``raise`` states one reason whatever values its message quotes, so a flood of bad values
    of one kind is one reason; the number of reasons is bounded by the code's raise sites."""
    frames = traceback.extract_tb(err.__traceback__)
    where = (frames[-1].filename, frames[-1].lineno or 0) if frames else ("", 0)
    return (type(err).__name__, *where)
