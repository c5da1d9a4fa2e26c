"""Zero crossings of a model's state events inside an integrator step.

A model's :class:`StateEvent` functions are evaluated at a step's ends; :func:`candidates`
finds, vectorised over every component, those that change sign or whose end values and rates
allow a dip to zero inside the step; :func:`dips` finds, for the latter, whether the step's
dense output does dip across zero and back (a near-tangent graze inside one step);
:func:`locate` finds the first time a candidate is on its new side with Brent's method on the
step's dense output. :class:`~tensegrity_core.sim.stepper.Stepper` uses both after
every step.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq, minimize_scalar

from tensegrity_core.events import EventKind

FloatArray = NDArray[np.float64]


class StateEvent(Protocol):
    """State events: the components of ``g(t, y)`` (an array, or one number) each cross zero in
    ``direction`` (-1 falling, +1 rising, 0 both). ``kind`` and ``indices`` (one per
    component) name a crossing in the event log. ``values(t, y)`` gives ``g`` and its time
    derivative along the motion (same shape; None where the model does not know it): the
    rate lets the stepper see a crossing and its return inside one step."""

    @property
    def kind(self) -> EventKind: ...

    @property
    def indices(self) -> tuple[int, ...]: ...

    @property
    def direction(self) -> float: ...

    def g(self, t: float, y: FloatArray) -> ArrayLike: ...

    def values(self, t: float, y: FloatArray) -> tuple[ArrayLike, ArrayLike | None]: ...


@dataclass(frozen=True)
class Crossing:
    """A located zero crossing: component ``component`` of ``event`` at time ``t`` [s],
    ``falling`` (from positive to negative) or rising."""

    t: float
    event: StateEvent
    component: int
    falling: bool = True

    @property
    def kind(self) -> EventKind:
        return self.event.kind

    @property
    def index(self) -> int:
        return self.event.indices[self.component]


class Interpolant(Protocol):
    """The solution over the current step (scipy's ``DenseOutput``, :class:`_Constant`,
    :class:`_LazyDense`): scalar ``t`` -> (n,), array (k,) -> (n, k)."""

    def __call__(self, t: float | FloatArray) -> FloatArray: ...


def event_values(ev: StateEvent, t: float, y: FloatArray) -> tuple[FloatArray, FloatArray | None]:
    g, rate = ev.values(t, y)
    return np.atleast_1d(np.asarray(g, dtype=float)), None if rate is None else np.atleast_1d(
        np.asarray(rate, dtype=float))


def candidates(direction: float, g0: FloatArray, r0: FloatArray | None, g1: FloatArray, r1: FloatArray | None,
                t0: float, t1: float) -> list[tuple[int, bool, float | None]]:
    """The components that may cross zero in ``[t0, t1]`` in ``direction``, as
    ``(component, falling, t_hi)``: a sign change between the ends is bracketed in
    ``[t0, t1]`` (``t_hi = t1``); a component on its old side at both ends whose end values
    and rates allow a dip to zero in between (its cubic Hermite interpolant can reach zero)
    has ``t_hi = None``, for :func:`dips` to look for the dip on the step's own dense output.
    Vectorised over the components: a step without a crossing costs a few array operations
    however many components there are."""
    h = t1 - t0
    # the common step: every component strictly on one side at both ends and, by the bound
    # below, unable to reach zero in between
    with np.errstate(invalid="ignore"):
        quiet = g0 * g1 > 0
        if r0 is not None and r1 is not None:
            quiet &= ~(np.minimum(np.abs(g0), np.abs(g1)) < (4.0 / 27.0) * h * (np.abs(r0) + np.abs(r1)))
    if quiet.all():
        return []
    out: list[tuple[int, bool, float | None]] = []
    for falling, sign in ((True, 1.0), (False, -1.0)):
        if direction * sign > 0:               # falling only for direction <= 0, rising only for >= 0
            continue
        a, b = sign * g0, sign * g1
        # from its old side to zero or the new one, or from exactly zero to the new one
        crossed = ((a > 0) & (b <= 0)) | ((a == 0) & (b < 0))
        out += [(int(k), falling, t1) for k in np.flatnonzero(crossed)]
        if r0 is None or r1 is None:
            continue
        # the cubic Hermite interpolant of the end values and rates is at least
        # min(a, b) - 4/27 h (|r0| + |r1|) (the end-slope basis functions stay within +-4/27
        # on the step): only components that may come near zero are looked at
        with np.errstate(invalid="ignore"):
            near = (a > 0) & (b > 0) & (np.minimum(a, b) < (4.0 / 27.0) * h * (np.abs(r0) + np.abs(r1)))
        out += [(int(k), falling, None) for k in np.flatnonzero(near)]
    return out


#: Points at which :func:`dips` samples the dense output across a step before refining the
#: lowest one: an event function over one step is a smooth, low-order curve (the
#: interpolant's polynomial through the event function), with at most a few extrema.
DIP_GRID = 16


def dips(ev: StateEvent, near: Sequence[tuple[int, bool]], dense: Interpolant, t0: float,
         t1: float) -> list[tuple[int, bool, float]]:
    """For each ``(component, falling)`` of ``near`` (on its old side at both ends of the step
    ``[t0, t1]``), the time ``t_hi`` of the lowest point of ``sign * g`` on the step's dense
    output (``sign`` +1 falling, -1 rising) where it is on the new side (``< 0``; the first
    such grid point if several): the component dips across zero and back inside the step,
    and its first crossing is bracketed in ``[t0, t_hi]``. Components that stay on their old side are left out.

    The end values and rates alone cannot decide a near-tangent graze: the integrator's
    interpolant may dip where the cubic through the ends does not. The minimum is found on
    the interpolant itself: sampled on a grid of :data:`DIP_GRID` intervals, then refined
    around the lowest sample with bounded Brent minimisation (``minimize_scalar``) unless the
    samples' curvature rules a dip between them out."""
    ts = np.linspace(t0, t1, DIP_GRID + 1)[1:-1]          # the ends are known to be on the old side
    ys = dense(ts)
    gs = np.stack([np.atleast_1d(np.asarray(ev.g(float(t), ys[:, i]), dtype=float)) for i, t in enumerate(ts)])
    xatol = 64 * np.finfo(float).eps * max(1.0, abs(t1))
    out: list[tuple[int, bool, float]] = []
    for k, falling in near:
        sign = 1.0 if falling else -1.0
        values = sign * gs[:, k]
        across = np.flatnonzero(values < 0.0)
        if across.size:
            out.append((k, falling, float(ts[across[0]])))
            continue
        # between two samples h/16 apart, a curve of second difference d2 dips at most about
        # |d2|/8 below the lower sample: a lowest sample above |d2| (8 times that) is no dip
        if values.min() > np.abs(np.diff(values, 2)).max():
            continue
        i = int(np.argmin(values))
        lo, hi = (ts[i - 1] if i > 0 else t0), (ts[i + 1] if i + 1 < len(ts) else t1)

        def f(t: float, k: int = k, sign: float = sign) -> float:
            return sign * float(np.atleast_1d(ev.g(t, dense(t)))[k])

        best = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
        # a minimum at an end of the step is the end's own value (on the old side, perhaps
        # by rounding only, just after an event): not a dip
        if best.fun < 0.0 and t0 + 4 * xatol < best.x < t1 - 4 * xatol:
            out.append((k, falling, float(best.x)))
    return out


def locate(ev: StateEvent, k: int, falling: bool, dense: Interpolant, t0: float, t1: float) -> float | None:
    """The first time in ``[t0, t1]`` at which component ``k`` of ``ev.g`` is on its new side
    (< 0 falling, > 0 rising), found by Brent's method on the dense output (as ``solve_ivp``
    locates events) and moved past the root to the first point where the sign holds; None if
    the dense output is not on the new side at ``t1``."""
    sign = 1.0 if falling else -1.0

    def f(t: float) -> float:
        return sign * float(np.atleast_1d(ev.g(t, dense(t)))[k])

    if f(t1) > 0.0:
        return None
    eps = np.finfo(float).eps
    xtol = 4 * eps * max(1.0, abs(t1))
    te = t0 if f(t0) <= 0.0 else float(brentq(f, t0, t1, xtol=xtol, rtol=4 * eps))
    for _ in range(8):
        if f(te) < 0.0 or te >= t1:
            break
        te = min(t1, te + xtol)
    return te
