"""Zero crossings of a model's state events inside an integrator step.

A model's :class:`StateEvent` functions are evaluated at a step's ends; :func:`candidates`
finds, vectorised over every component, those that change sign, and those on their old side
at both ends that may dip across zero and back inside the step (a short excursion: a graze).
How such a dip is decided depends on what the function is:

- the distance to a hard stop (``hard_stop``: the fold limit's actuator length) is searched
  on the step's own dense output (:func:`dips`): a dip past a stop is a leak through it, and
  the cubic through the end values and rates can miss a near-tangent graze that the
  integrated motion makes;
- any other function (a held actuator's contact force, a string's gap) dips where the cubic
  Hermite interpolant of its end values and rates does (:func:`hermite_minimum`).

:func:`locate` then finds the first time a candidate is on its new side with Brent's method
on the step's dense output. :class:`~tensegrity_core.sim.stepper.Stepper` uses them after
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
from tensegrity_core.sim.interpolants import Interpolant

FloatArray = NDArray[np.float64]


class StateEvent(Protocol):
    """State events: the components of ``g(t, y)`` (an array, or one number) each cross zero in
    ``direction`` (-1 falling, +1 rising, 0 both). ``kind`` and ``indices`` (one per
    component) name a crossing in the event log. ``values(t, y)`` gives ``g`` and its time
    derivative along the motion (same shape; None where the model does not know it): the
    rate lets the stepper see a crossing and its return inside one step.

    ``hard_stop`` is True where ``g`` is the distance [m] to a hard stop (a position of the
    state, crossed only through an impact): a dip across it inside a step is looked for on
    the step's dense output. False for a function whose dip the end values and rates decide:
    a contact force (an algebraic function of the state through the accelerations: on a loose
    implicit method's interpolant it wiggles about zero just after a fold, and those wiggles
    are the interpolant's error, not a release) or a string's gap (a string slack for a
    graze the cubic misses changes the force by a kink within the integration tolerance; a
    missed stop is a leak)."""

    @property
    def kind(self) -> EventKind: ...

    @property
    def indices(self) -> tuple[int, ...]: ...

    @property
    def direction(self) -> float: ...

    @property
    def hard_stop(self) -> bool: ...

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


def event_values(ev: StateEvent, t: float, y: FloatArray) -> tuple[FloatArray, FloatArray | None]:
    g, rate = ev.values(t, y)
    return np.atleast_1d(np.asarray(g, dtype=float)), None if rate is None else np.atleast_1d(
        np.asarray(rate, dtype=float))


def candidates(direction: float, g0: FloatArray, r0: FloatArray | None, g1: FloatArray, r1: FloatArray | None,
               t0: float, t1: float, *, dense_dips: bool = False) -> list[tuple[int, bool, float | None]]:
    """The components that may cross zero in ``[t0, t1]`` in ``direction``, as
    ``(component, falling, t_hi)``: the crossing is bracketed in ``[t0, t_hi]`` if the
    component's sign at ``t_hi`` is the new one (``t_hi = t1`` for a sign change between the
    ends; inside the step where the Hermite cubic of the end values and rates dips across
    zero and back). With ``dense_dips`` a component on its old side at both ends that may come
    near zero in between (by the bound below) has ``t_hi = None`` instead: :func:`dips` decides
    on the step's dense output. Vectorised over the components: a step without a crossing
    costs a few array operations however many components there are."""
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
        m0, m1 = sign * r0 * h, sign * r1 * h
        # the cubic is at least min(a, b) - 4/27 (|m0| + |m1|) (the end-slope basis functions
        # stay within +-4/27 on [0, 1]): only components that may reach zero are looked at
        with np.errstate(invalid="ignore"):
            near = (a > 0) & (b > 0) & (np.minimum(a, b) < (4.0 / 27.0) * (np.abs(m0) + np.abs(m1)))
        if not near.any():
            continue
        k = np.flatnonzero(near)
        if dense_dips:
            out += [(int(j), falling, None) for j in k]
            continue
        s, p = hermite_minimum(a[k], m0[k], b[k], m1[k])
        out += [(int(k[j]), falling, t0 + float(s[j]) * h) for j in np.flatnonzero(p < 0)]
    return out


def hermite_minimum(p0: FloatArray, m0: FloatArray, p1: FloatArray,
                     m1: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(s, p(s))`` at the interior minimum over ``s`` in (0, 1) of the cubic Hermite
    interpolant with end values ``p0, p1`` and end slopes ``m0, m1`` (per unit ``s``);
    ``p(s) = inf`` where it has none inside."""
    # p'(s) = A s^2 + B s + m0, p''(s) = 2 A s + B
    A = 6 * p0 + 3 * m0 - 6 * p1 + 3 * m1
    B = -6 * p0 - 4 * m0 + 6 * p1 - 2 * m1
    disc = B * B - 4 * A * m0
    s_best = np.full(np.shape(p0), 0.5)
    p_best = np.full(np.shape(p0), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        quadratic = A != 0
        root = np.sqrt(np.maximum(disc, 0.0))
        linear = -m0 / B
        for s in (np.where(quadratic, (-B + root) / (2 * A), linear),
                  np.where(quadratic, (-B - root) / (2 * A), np.nan)):
            ok = np.isfinite(s) & (s > 0) & (s < 1) & ((disc >= 0) | ~quadratic) & (2 * A * s + B > 0)
            p = ((2 * s**3 - 3 * s**2 + 1) * p0 + (s**3 - 2 * s**2 + s) * m0 + (-2 * s**3 + 3 * s**2) * p1
                 + (s**3 - s**2) * m1)
            better = ok & (p < p_best)
            s_best = np.where(better, s, s_best)
            p_best = np.where(better, p, p_best)
    return s_best, p_best


#: Intervals of the grid on which :func:`dips` samples a step's dense output before refining
#: around the lowest sample: over one step an event function is a smooth, low-order curve
#: (the interpolant's polynomial through it), with at most a few extrema.
DIP_GRID = 16


def dips(ev: StateEvent, near: Sequence[tuple[int, bool]], dense: Interpolant, t0: float, t1: float,
         floor: float = 0.0) -> list[tuple[int, bool, float]]:
    """For each ``(component, falling)`` of ``near`` (on its old side at both ends of the step
    ``[t0, t1]``), a time ``t_hi`` inside the step where ``sign * g`` (``sign`` +1 falling, -1
    rising) on the step's dense output is below ``-floor``: the component dips across zero and
    back, and its first crossing is bracketed in ``[t0, t_hi]``. Components that stay above
    ``-floor`` are left out.

    The lowest point is found on the interpolant itself: sampled at the :data:`DIP_GRID`
    interior grid points, then refined around the lowest sample with bounded Brent
    minimisation (``minimize_scalar``), unless the samples' curvature rules a dip out. Only
    the interior is searched: an end is on the old side by the caller's test (perhaps by
    rounding only, just after an event), so a minimum there is no dip."""
    ts = np.linspace(t0, t1, DIP_GRID + 1)[1:-1]
    ys = dense(ts)
    gs = np.stack([np.atleast_1d(np.asarray(ev.g(float(t), ys[:, i]), dtype=float)) for i, t in enumerate(ts)])
    xatol = 64 * np.finfo(float).eps * max(1.0, abs(t1))
    out: list[tuple[int, bool, float]] = []
    for k, falling in near:
        sign = 1.0 if falling else -1.0
        values = sign * gs[:, k]
        across = np.flatnonzero(values < -floor)
        if across.size:
            out.append((k, falling, float(ts[across[0]])))
            continue
        # between two samples h/16 apart a curve whose second difference is d2 dips at most
        # about |d2|/8 below the lower one (a parabola's sag): a lowest sample above |d2|
        # (eight times that, for the higher-order terms) leaves no dip to find
        if values.min() - floor > np.abs(np.diff(values, 2)).max():
            continue
        i = int(np.argmin(values))
        lo, hi = (ts[i - 1] if i > 0 else t0), (ts[i + 1] if i + 1 < len(ts) else t1)

        def f(t: float, k: int = k, sign: float = sign) -> float:
            return sign * float(np.atleast_1d(ev.g(t, dense(t)))[k])

        best = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
        if best.fun < -floor and t0 + 4 * xatol < best.x < t1 - 4 * xatol:
            out.append((k, falling, float(best.x)))
    return out


def locate(ev: StateEvent, k: int, falling: bool, dense: Interpolant, t0: float, t1: float) -> float | None:
    """The first time in ``[t0, t1]`` at which component ``k`` of ``ev.g`` is on its new side
    (< 0 falling, > 0 rising), found by Brent's method on the dense output (as ``solve_ivp``
    locates events) and moved past the root to the first point where the sign holds; None if
    the dense output is not on the new side at ``t1`` (a dip of the Hermite cubic only)."""
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
