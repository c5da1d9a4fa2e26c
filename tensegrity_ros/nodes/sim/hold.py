"""The command the simulator holds between commands, and what happens when commands stop.
Plain logic, no node: the node passes the (steady) wall time.

Free-running, the simulation runs under the last valid command (zero-order hold). When no
valid command has come for ``timeout`` seconds while playing, the hold falls back to
``safe`` (actuator forces: ``safe_force`` on every actuator) until the next command; an
input without a safe value (a rest length: a motor holds its position) is held as it is,
and there is nothing to time out. The timeout counts wall time while playing only: a pause
stops the command's clock (:meth:`CommandHold.pause`, :meth:`CommandHold.resume`), so
neither the pause itself nor stepping requests made during it time a command out, and play
after a pause goes on under the command it was paused with. Before the first command (and
after a reset) the scene's initial command holds and nothing times out.
"""

from __future__ import annotations

from collections.abc import Sequence


class CommandHold:
    """The held command of one simulation: ``values`` (one per input, input order)."""

    def __init__(self, initial: Sequence[float], timeout: float, safe: Sequence[float] | None):
        self.timeout = timeout
        self.safe = None if safe is None else [float(v) for v in safe]
        self.values = [float(v) for v in initial]
        self.timed_out = False
        self._last: float | None = None         # wall time of the last valid command (playing)
        self._paused = False
        self._paused_age: float | None = None   # its age when the clock was paused (None: none yet)

    def reset(self, initial: Sequence[float]) -> None:
        """The scene's initial command again; no command since."""
        self.values = [float(v) for v in initial]
        self._last = None
        self._paused_age = None
        self.timed_out = False

    def set(self, values: Sequence[float], now: float) -> bool:
        """A valid command at wall time ``now``: hold ``values``. True when it ends a timeout
        (commands resumed)."""
        self.values = [float(v) for v in values]
        if self._paused:
            self._paused_age = 0.0
        else:
            self._last = now
        resumed, self.timed_out = self.timed_out, False
        return resumed

    def pause(self, now: float) -> None:
        """Stop the command's clock (the simulation no longer plays)."""
        if not self._paused:
            self._paused_age = self.age(now)
            self._paused = True

    def resume(self, now: float) -> None:
        """Start the command's clock again where it stopped."""
        if self._paused:
            self._paused = False
            self._last = None if self._paused_age is None else now - self._paused_age

    def age(self, now: float) -> float | None:
        """Wall seconds of play since the last valid command, or None before the first."""
        if self._paused:
            return self._paused_age
        return None if self._last is None else now - self._last

    def effective(self, now: float) -> tuple[list[float], bool]:
        """The command a step at wall time ``now`` runs under, and whether the timeout
        happened just now (to say so once)."""
        age = self.age(now)
        if self.safe is None or self.timeout <= 0 or age is None or age <= self.timeout:
            return self.values, False
        just, self.timed_out = not self.timed_out, True
        return list(self.safe), just

    def fallback(self) -> list[float]:
        """What a step runs under when its command did not come (lockstep timeout): the safe
        command, or the held one for inputs without a safe value."""
        return list(self.values) if self.safe is None else list(self.safe)
