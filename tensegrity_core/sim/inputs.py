"""Input laws of the actuators: what the scene's ``inputs`` section builds.

For the class-2 mechanism an input is the actuator *force* [N], positive = tensile (the
generalised force on ``rho_i`` is ``-f_i``, the paper's Eq. 48). For a general structure it
is the *rest length* [m] of an actuator member. Each law gives

- ``value_at(t, length)``: the input at time ``t`` [s] when the actuator has length ``length`` [m];
- ``potential(t, length)``: ``int_0^length value_at(t, l) dl``, the actuator's potential at
  frozen ``t`` (its generalised force ``-value`` is conservative in the length; the
  quasi-static model minimises it together with the springs' energy);
- ``d_length(t, length)`` and ``d_time(t, length)``: its partial derivatives (for the
  integrator's Jacobian and the quasi-static path tangent);
- ``local(t, length)``: value and both derivatives at one point (floats);
- ``arrays(t, length)``: value and both derivatives for arrays of samples;
- ``breakpoints``: times where the law is not smooth; integrators stop and restart there so
  that no step straddles a kink or jump.

Laws: :class:`Constant`, :class:`Ramp` (linear between two times, constant outside),
:class:`Proportional` (``gain * length * t``, the paper's ``f_i = 10 rho_i t``),
:class:`Series` (a time series read from CSV, interpolated) and :class:`Commanded` (the scene's
"commanded": the simulator holds the last command given to it; :func:`held` turns the laws
and a state's commands into laws a model evaluates, a command becoming a :class:`Constant`).

Every law is immutable: a new command is a new set of laws, never a changed one.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

INTERPOLATIONS = ("linear", "previous", "cubic")

FloatArray = NDArray[np.float64]
#: ``(value, d/dlength, d/dt)`` over samples (arrays of one shape).
LawArrays = tuple[FloatArray, FloatArray, FloatArray]


class Law(Protocol):
    """What a model evaluates: an input law with a value at every time and length (every law
    here but :class:`Commanded`, which :func:`held` replaces by a :class:`Constant`)."""

    @property
    def law(self) -> str:
        """The law's name in the scene (``"constant"``, ``"ramp"``, ...)."""
        ...

    @property
    def breakpoints(self) -> tuple[float, ...]: ...

    def value_at(self, t: float, length: float) -> float: ...

    def potential(self, t: float, length: float) -> float: ...

    def d_length(self, t: float, length: float) -> float: ...

    def d_time(self, t: float, length: float) -> float: ...

    def local(self, t: float, length: float) -> tuple[float, float, float]: ...

    def arrays(self, t: ArrayLike, length: ArrayLike) -> LawArrays: ...


class _TimeDependent(Protocol):
    """What :class:`_TimeLaw` needs of the law it is mixed into."""

    def value_at(self, t: float, length: float) -> float: ...

    def d_time(self, t: float, length: float) -> float: ...


class _TimeLaw:
    """Shared parts of the laws that depend on time only."""

    def potential(self: _TimeDependent, t: float, length: float) -> float:
        return self.value_at(t, length) * length

    def d_length(self, t: float, length: float) -> float:
        return 0.0

    def local(self: _TimeDependent, t: float, length: float) -> tuple[float, float, float]:
        return self.value_at(t, length), 0.0, self.d_time(t, length)


class _ConstantValue(_TimeLaw):
    """A law whose value is the attribute ``value``."""

    value: float
    breakpoints: ClassVar[tuple[float, ...]] = ()

    def value_at(self, t: float, length: float) -> float:
        return self.value

    def d_time(self, t: float, length: float) -> float:
        return 0.0

    def arrays(self, t: ArrayLike, length: ArrayLike) -> LawArrays:
        z = np.zeros(np.broadcast(t, length).shape)
        return z + self.value, z, z


@dataclass(frozen=True)
class Constant(_ConstantValue):
    """``u(t) = value``."""

    value: float
    law: ClassVar[str] = "constant"


@dataclass(frozen=True)
class Ramp(_TimeLaw):
    """``u = start_value`` before ``t0``, linear to ``end_value`` at ``t1``, constant after."""

    start_value: float
    end_value: float
    t0: float
    t1: float
    law: ClassVar[str] = "ramp"

    @property
    def breakpoints(self) -> tuple[float, ...]:
        return (self.t0, self.t1)

    def value_at(self, t: float, length: float) -> float:
        if t <= self.t0:
            return self.start_value
        if t >= self.t1:
            return self.end_value
        return self.start_value + (self.end_value - self.start_value) * (t - self.t0) / (self.t1 - self.t0)

    def d_time(self, t: float, length: float) -> float:
        if self.t0 <= t < self.t1:
            return (self.end_value - self.start_value) / (self.t1 - self.t0)
        return 0.0

    def arrays(self, t: ArrayLike, length: ArrayLike) -> LawArrays:
        ts = np.broadcast_to(np.asarray(t, dtype=float), np.broadcast(t, length).shape)
        slope = (self.end_value - self.start_value) / (self.t1 - self.t0)
        u = self.start_value + slope * (np.clip(ts, self.t0, self.t1) - self.t0)
        return u, np.zeros_like(u), np.where((ts >= self.t0) & (ts < self.t1), slope, 0.0)


@dataclass(frozen=True)
class Proportional:
    """``u = gain * length * t``: the paper's ``f_i = 10 rho_i t`` (gain 10 N/(m s))."""

    gain: float
    law: ClassVar[str] = "proportional"
    breakpoints: ClassVar[tuple[float, ...]] = ()

    def value_at(self, t: float, length: float) -> float:
        return self.gain * length * t

    def potential(self, t: float, length: float) -> float:
        return 0.5 * self.gain * t * length * length

    def d_length(self, t: float, length: float) -> float:
        return self.gain * t

    def d_time(self, t: float, length: float) -> float:
        return self.gain * length

    def local(self, t: float, length: float) -> tuple[float, float, float]:
        return self.gain * length * t, self.gain * t, self.gain * length

    def arrays(self, t: ArrayLike, length: ArrayLike) -> LawArrays:
        ts, ls = np.broadcast_arrays(np.asarray(t, dtype=float), np.asarray(length, dtype=float))
        return self.gain * ls * ts, self.gain * ts, self.gain * ls


@dataclass(frozen=True)
class Series(_TimeLaw):
    """A time series ``(times, values)`` with ``interpolation`` "linear", "previous" (zero-order
    hold) or "cubic" (natural C2 spline); held constant before the first and after the last
    sample."""

    times: tuple[float, ...]
    values: tuple[float, ...]
    interpolation: str = "linear"
    source: str = ""
    law: ClassVar[str] = "series"
    _t: FloatArray = field(init=False, repr=False, compare=False)
    _v: FloatArray = field(init=False, repr=False, compare=False)
    #: The cubic spline ``(t, derivative order=0) -> values`` or None.
    _spline: Callable[..., FloatArray] | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        object.__setattr__(self, "_t", t)
        object.__setattr__(self, "_v", v)
        spline = None
        if self.interpolation == "cubic":
            from scipy.interpolate import CubicSpline

            spline = CubicSpline(t, v, bc_type="natural")
        object.__setattr__(self, "_spline", spline)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        if self.interpolation == "cubic":
            return (float(self._t[0]), float(self._t[-1]))
        return tuple(float(x) for x in self._t)

    def value_at(self, t: float, length: float) -> float:
        return float(self.arrays(t, length)[0])

    def d_time(self, t: float, length: float) -> float:
        return float(self.arrays(t, length)[2])

    def arrays(self, t: ArrayLike, length: ArrayLike) -> LawArrays:
        ts, vs = self._t, self._v
        tt = np.broadcast_to(np.asarray(t, dtype=float), np.broadcast(t, length).shape)
        inside = (tt >= ts[0]) & (tt < ts[-1])
        if self.interpolation == "previous":
            i = np.clip(np.searchsorted(ts, tt, side="right") - 1, 0, len(ts) - 1)
            return vs[i], np.zeros(tt.shape), np.zeros(tt.shape)
        if self._spline is not None:
            tc = np.clip(tt, ts[0], ts[-1])
            return self._spline(tc), np.zeros(tt.shape), np.where(inside, self._spline(tc, 1), 0.0)
        i = np.clip(np.searchsorted(ts, tt, side="right") - 1, 0, max(len(ts) - 2, 0))
        slope = np.diff(vs) / np.diff(ts) if len(ts) > 1 else np.zeros(1)
        return np.interp(tt, ts, vs), np.zeros(tt.shape), np.where(inside, slope[i], 0.0)


@dataclass(frozen=True)
class Commanded:
    """The scene's "commanded" input: the value before the first command is ``initial``, or
    (``None``) the one that keeps the initial state at rest (class-2: ``f_i = -dU/drho_i``;
    general: the member's rest length)."""

    initial: float | None = None
    law: ClassVar[str] = "commanded"


#: An input law as a scene lists it.
InputLaw = Law | Commanded


def held(laws: Iterable[InputLaw], commands: Sequence[float]) -> tuple[Law, ...]:
    """``laws`` with each commanded input held at its command: a :class:`Constant` of
    ``commands[i]`` in place of a :class:`Commanded` (other laws unchanged)."""
    return tuple(Constant(float(c)) if isinstance(law, Commanded) else law for law, c in zip(laws, commands))


def next_breakpoint(laws: Iterable[Law], t: float, t_end: float) -> float:
    """The first breakpoint of any law strictly after ``t`` (with a relative margin), or ``t_end``."""
    margin = 1e-12 * max(1.0, abs(t))
    best = t_end
    for law in laws:
        for b in law.breakpoints:
            if t + margin < b < best:
                best = b
    return best
