"""The inputs a page's sliders set, and the clamping of a value to its limits.

An :class:`InputSpec` is one slider: an actuator force [N] of the class-2 mechanism
(tension positive), a rest length [m] of an actuated member of a general structure, or a
robot motor's command in its mode (rest length [m], tension [N], reel speed [m/s]);
:func:`command_input` makes the latter two from the simulator's limits.
:func:`clamp` brings a value inside its limits and says so in one line, which the page
shows; a value that is not a finite number is refused (the input keeps its value).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Rest-length sliders without a finite range span this fraction of the rest length either way.
REST_LENGTH_SPAN = 0.5
#: The unit of a command, by the motor mode that takes it.
MODE_UNITS = {"rest_length": "m", "tension": "N", "reel_speed": "m/s"}


@dataclass(frozen=True)
class InputSpec:
    """One input: ``name``, ``unit``, limits ``low`` <= ``high`` and the ``initial`` value."""

    name: str
    unit: str
    low: float
    high: float
    initial: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise ValueError(f"input {self.name}: limits [{self.low}, {self.high}] are not an interval")


@dataclass(frozen=True)
class Clamped:
    """The value to apply and the note for the page ("" when the value was within limits)."""

    value: float
    note: str = ""


def clamp(spec: InputSpec, value: float, current: float) -> Clamped:
    """``value`` within ``[spec.low, spec.high]``; ``current`` is kept for a non-finite value."""
    v = float(value)
    if not math.isfinite(v):
        return Clamped(current, f"{spec.name}: {value!r} is not a number; kept {current:g} {spec.unit}")
    if spec.low <= v <= spec.high:
        return Clamped(v)
    limit = spec.high if v > spec.high else spec.low
    return Clamped(limit, f"{spec.name} = {v:g} {spec.unit} is outside [{spec.low:g}, {spec.high:g}] "
                          f"{spec.unit}: clamped to {limit:g} {spec.unit}")


def command_input(name: str, value: float, limits: tuple[float, float], mode: str = "rest_length") -> InputSpec:
    """The slider of an input commanded in ``mode`` (its unit :data:`MODE_UNITS`) at ``value``,
    within the simulator's ``limits`` (``Interface.limits``: an open interval, a motor's range
    widened by one ulp, so its ends are the range's); a rest length without a finite range (a
    general structure's actuated member, ``(0, inf)``) spans :data:`REST_LENGTH_SPAN` of
    ``value`` either way, inside ``limits``."""
    lo, hi = math.nextafter(limits[0], math.inf), math.nextafter(limits[1], -math.inf)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        lo, hi = max(lo, (1 - REST_LENGTH_SPAN) * value), min(hi, (1 + REST_LENGTH_SPAN) * value)
    return InputSpec(name, MODE_UNITS[mode], lo, hi, min(max(value, lo), hi))
