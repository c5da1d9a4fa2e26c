"""Input laws of the actuators: what the scene's ``inputs`` section builds.

For the class-2 mechanism an input is the actuator *force* [N], positive = tensile (the
generalised force on ``rho_i`` is ``-f_i``, the paper's Eq. 48). For a general structure it
is the *rest length* [m] of an actuator member. Each law gives

- ``value(t, length)``: the input at time ``t`` [s] when the actuator has length ``length`` [m];
- ``d_length(t, length)`` and ``d_time(t, length)``: its partial derivatives (for the
  integrator's Jacobian and the quasi-static path tangent);
- ``breakpoints``: times where the law is not smooth; integrators stop and restart there so
  that no step straddles a kink or jump.

Laws: :class:`Constant`, :class:`Ramp` (linear between two times, constant outside),
:class:`Proportional` (``gain * length * t``, the paper's ``f_i = 10 rho_i t``),
:class:`Series` (a time series read from CSV, interpolated) and :class:`Commanded`
(zero-order hold of the last command given to the simulator).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

INTERPOLATIONS = ("linear", "previous", "cubic")


@dataclass(frozen=True)
class Constant:
    """``u(t) = value``."""

    value: float
    law = "constant"
    breakpoints = ()
    state_dependent = False

    def value_at(self, t: float, length: float) -> float:
        return self.value

    def d_length(self, t: float, length: float) -> float:
        return 0.0

    def d_time(self, t: float, length: float) -> float:
        return 0.0


@dataclass(frozen=True)
class Ramp:
    """``u = start_value`` before ``t0``, linear to ``end_value`` at ``t1``, constant after."""

    start_value: float
    end_value: float
    t0: float
    t1: float
    law = "ramp"
    state_dependent = False

    @property
    def breakpoints(self) -> tuple:
        return (self.t0, self.t1)

    def value_at(self, t: float, length: float) -> float:
        if t <= self.t0:
            return self.start_value
        if t >= self.t1:
            return self.end_value
        return self.start_value + (self.end_value - self.start_value) * (t - self.t0) / (self.t1 - self.t0)

    def d_length(self, t: float, length: float) -> float:
        return 0.0

    def d_time(self, t: float, length: float) -> float:
        if self.t0 <= t < self.t1:
            return (self.end_value - self.start_value) / (self.t1 - self.t0)
        return 0.0


@dataclass(frozen=True)
class Proportional:
    """``u = gain * length * t``: the paper's ``f_i = 10 rho_i t`` (gain 10 N/(m s))."""

    gain: float
    law = "proportional"
    breakpoints = ()
    state_dependent = True

    def value_at(self, t: float, length: float) -> float:
        return self.gain * length * t

    def d_length(self, t: float, length: float) -> float:
        return self.gain * t

    def d_time(self, t: float, length: float) -> float:
        return self.gain * length


@dataclass(frozen=True)
class Series:
    """A time series ``(times, values)`` with ``interpolation`` "linear", "previous" (zero-order
    hold) or "cubic" (C2 spline); held constant before the first and after the last sample."""

    times: tuple
    values: tuple
    interpolation: str = "linear"
    source: str = ""
    law = "series"
    state_dependent = False
    _t: np.ndarray = field(init=False, repr=False, compare=False)
    _v: np.ndarray = field(init=False, repr=False, compare=False)
    _spline: object = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        object.__setattr__(self, "_t", t)
        object.__setattr__(self, "_v", v)
        spline = None
        if self.interpolation == "cubic" and len(t) >= 2:
            from scipy.interpolate import CubicSpline

            spline = CubicSpline(t, v, bc_type="natural")
        object.__setattr__(self, "_spline", spline)

    @property
    def breakpoints(self) -> tuple:
        if self.interpolation == "cubic":
            return (float(self._t[0]), float(self._t[-1]))
        return tuple(float(x) for x in self._t)

    def value_at(self, t: float, length: float) -> float:
        ts = self._t
        if t <= ts[0]:
            return float(self._v[0])
        if t >= ts[-1]:
            return float(self._v[-1])
        if self.interpolation == "previous":
            return float(self._v[np.searchsorted(ts, t, side="right") - 1])
        if self._spline is not None:
            return float(self._spline(t))
        return float(np.interp(t, ts, self._v))

    def d_length(self, t: float, length: float) -> float:
        return 0.0

    def d_time(self, t: float, length: float) -> float:
        ts = self._t
        if t < ts[0] or t >= ts[-1] or self.interpolation == "previous":
            return 0.0
        if self._spline is not None:
            return float(self._spline(t, 1))
        i = int(np.searchsorted(ts, t, side="right")) - 1
        return float((self._v[i + 1] - self._v[i]) / (ts[i + 1] - ts[i]))


@dataclass(frozen=True)
class Commanded:
    """Zero-order hold of the last value given to :meth:`Simulator.set_command`.

    ``initial`` is the value before the first command; ``None`` means "hold": the input
    that keeps the initial state at rest (class-2: ``f_i = -dU/drho_i``; general: the
    member's rest length)."""

    initial: float | None = None
    law = "commanded"
    breakpoints = ()
    state_dependent = False

    def value_at(self, t: float, length: float) -> float:  # pragma: no cover - replaced at run time
        raise TypeError("a commanded input has no law; the simulator holds the last command")

    def d_length(self, t: float, length: float) -> float:
        return 0.0

    def d_time(self, t: float, length: float) -> float:
        return 0.0


LAWS = {"constant": Constant, "ramp": Ramp, "proportional": Proportional, "series": Series,
        "commanded": Commanded}


class HeldCommand:
    """The run-time form of a :class:`Commanded` input: a value that only changes when the
    simulator is given a new command (then the integrator restarts)."""

    law = "commanded"
    breakpoints = ()
    state_dependent = False

    def __init__(self, value: float):
        self.value = float(value)

    def value_at(self, t: float, length: float) -> float:
        return self.value

    def d_length(self, t: float, length: float) -> float:
        return 0.0

    def d_time(self, t: float, length: float) -> float:
        return 0.0


def next_breakpoint(laws, t: float, t_end: float) -> float:
    """The first breakpoint of any law strictly after ``t`` (with a relative margin), or ``t_end``."""
    margin = 1e-12 * max(1.0, abs(t))
    best = t_end
    for law in laws:
        for b in law.breakpoints:
            if t + margin < b < best:
                best = b
    return best


def is_finite_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
