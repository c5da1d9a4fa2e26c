"""Which of the slower topics go out with a publication. Plain logic, no node.

Every publication (one per free-running tick, lockstep step or republished state) carries
the fast topics; a slower topic with rate ``r`` [Hz] goes out with every n-th publication,
``n = round(publish_rate / r)`` (at least 1; a divisor of ``publish_rate`` is exact), the
first publication included; rate 0 = never. A rate above ``publish_rate`` is capped at it
(every publication carries the topic), as ros2_control runs a controller whose update rate
is above its controller manager's at the manager's rate; the node says so in its log at start
(:func:`cap_warnings`), as the controller manager does.
"""

from __future__ import annotations

from collections.abc import Mapping


class Decimation:
    """Counts publications and says which slower topics are due with each."""

    def __init__(self, publish_rate: float, rates: Mapping[str, float]):
        self.every = {name: max(1, round(publish_rate / r)) if r > 0 else 0 for name, r in rates.items()}
        self._on = tuple((name, every) for name, every in self.every.items() if every)
        self.count = 0

    def next(self) -> frozenset[str]:
        """The slower topics due with this publication (counting it)."""
        n, self.count = self.count, self.count + 1
        return frozenset(name for name, every in self._on if n % every == 0) if self._on else _NONE


_NONE: frozenset[str] = frozenset()


def cap_warnings(publish_rate: float, rates: Mapping[str, float]) -> list[str]:
    """One line for each parameter of ``rates`` (parameter name -> rate [Hz]) above
    ``publish_rate`` [Hz]: its topics go out with every publication, at ``publish_rate``."""
    return [f"parameter {name} = {rate:g} Hz is above publish_rate = {publish_rate:g} Hz: its topics go out with "
            f"every publication, at {publish_rate:g} Hz" for name, rate in rates.items() if rate > publish_rate]
