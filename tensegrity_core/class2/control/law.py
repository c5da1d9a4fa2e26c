"""The tracking law: feedforward along a reference plus gain-scheduled discrete LQR feedback.

Each tick, at time ``t`` on the measured state ``x = (q, qdot)``::

    u = clip(u_r(tau + dt/2) - K(tau) [x - x_r(tau); z], -f_max, f_max)
    z <- z + dt (D(q) - D_r(tau))        (only while u is not clipped and |D - D_r| < band)

with ``tau = t - t_start`` the reference's own time. ``u_r`` is sampled half a period
ahead: it is held for the period ``[t, t + dt)``, and its value at the midpoint is the
period's mean to second order. ``K(tau)`` is designed (:func:`~tensegrity_core.class2.control.lqr.design_gain`)
on the linearisation about the reference at knots every ``gain_spacing`` seconds of the
reference and at its end, and interpolated linearly between them (gain scheduling along
the reference). When a reference ends its last sample is held: that is rest with the
holding forces for every reference the planners make.

The integral ``z`` of D's error [m s] makes a constant unmodelled load settle with no
error of D. Anti-windup: it is frozen while the output saturates and while D is further
than ``integral_band`` from its reference (a transient, e.g. after a preemption, is the
proportional part's job; integrating it would leave a slow tail), and bounded so that it
alone cannot ask for more than ``f_max``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.control.lqr import DEFAULT_WEIGHTS, Gain, LQRWeights, Vector, design_gain
from tensegrity_core.class2.control.reference import Reference, ReferenceSample, hold_reference
from tensegrity_core.class2.inverse_kinematics import nearest_solution
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import ParameterError, TensegrityError

#: Largest number of gain-schedule knots per reference (each is one Riccati solve, ~1-3 ms).
MAX_KNOTS: Final = 40
#: Weights while an actuator trajectory runs: the lengths' errors dominate (1 mm, 1 cm/s).
ACTUATOR_WEIGHTS: Final = LQRWeights(position=0.05, velocity=0.5, length=0.001, rate=0.01)


@dataclass(frozen=True)
class ScheduledGains:
    """Gains at the reference times ``times`` [s] (uniform), interpolated linearly."""

    times: NDArray[np.float64]
    K: NDArray[np.float64]          # (n, 2, 8)
    designs: tuple[Gain, ...]       # the Gain of each knot (poles for reports)

    def at(self, tau: float) -> NDArray[np.float64]:
        n = len(self.times) - 1
        K: NDArray[np.float64]
        if n == 0 or tau <= 0.0:
            K = self.K[0]
            return K
        x = tau / self.times[1]
        if x >= n:
            K = self.K[n]
            return K
        i = int(x)
        w = x - i
        K = self.K[i] + w * (self.K[i + 1] - self.K[i])
        return K


def schedule_gains(reference: Reference, params: Class2Params, weights: LQRWeights, dt: float,
                   spacing: float, motion_weights: LQRWeights | None = None) -> ScheduledGains:
    """Design the gains along ``reference`` at knots at most ``spacing`` [s] apart (at most
    :data:`MAX_KNOTS` of them: a slow reference moves little between knots);
    ``motion_weights`` (default ``weights``) for the knots before the end, ``weights`` at
    the end, where the reference rests."""
    T = reference.duration
    n = min(MAX_KNOTS, max(1, int(math.ceil(T / spacing - 1e-9)))) if T > 0 else 0
    times = np.linspace(0.0, T, n + 1)
    designs: list[Gain] = []
    for k, tau in enumerate(times):
        s = reference.sample(float(tau))
        w = weights if (k == n or motion_weights is None) else motion_weights
        designs.append(design_gain(s.q, s.qdot, s.force, params, w, dt))
    return ScheduledGains(times, np.array([g.K for g in designs]), tuple(designs))


@dataclass(frozen=True)
class Tick:
    """What one tick computed: the forces and what they were computed from."""

    forces: NDArray[np.float64]          # commanded (f1, f2) [N], within the limit
    unsaturated: NDArray[np.float64]     # before clipping [N]
    desired: ReferenceSample             # the reference at the tick
    end_effector: NDArray[np.float64]    # measured D [m]
    tau: float                  # time along the reference [s]


class TrackingController:
    """Feedforward + gain-scheduled LQR tracking of :class:`Reference` objects.

    ``dt`` [s] the sampling period the gains are designed for; ``max_force`` [N] the
    actuator force limit (symmetric); ``weights`` the LQR scales; ``gain_spacing`` [s] the
    knot spacing of the gain schedule; ``integral_band`` [m] the error of D below which
    the integral runs. Start with :meth:`hold` or :meth:`follow`, then call
    :meth:`update` once per period with the measured state.
    """

    def __init__(self, params: Class2Params = PAPER_PARAMS, *, dt: float = 0.01, max_force: float = 5.0,
                 weights: LQRWeights = DEFAULT_WEIGHTS, gain_spacing: float = 0.1, integral_band: float = 0.01,
                 actuator_weights: LQRWeights | None = None) -> None:
        for name, v in (("dt", dt), ("max_force", max_force), ("gain_spacing", gain_spacing),
                        ("integral_band", integral_band)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be a finite number > 0, got {v!r}")
        self.params = params
        self.dt = float(dt)
        self.max_force = float(max_force)
        self.weights = weights
        self.actuator_weights = ACTUATOR_WEIGHTS if actuator_weights is None else actuator_weights
        self.gain_spacing = float(gain_spacing)
        self.integral_band = float(integral_band)
        self.reference: Reference | None = None
        self.gains: ScheduledGains | None = None
        self.t_start = 0.0
        self.z = np.zeros(2)
        self._t_last: float | None = None

    # -- references -------------------------------------------------------------------
    def schedule(self, reference: Reference) -> ScheduledGains:
        """The gain schedule for ``reference`` (the costly part of starting one: ~1-3 ms per knot).
        While an actuator trajectory runs the lengths are weighed (:data:`ACTUATOR_WEIGHTS`):
        its reference is quasi-static (beta on its equilibrium), not a trajectory of the
        dynamics, and the default weights would bend the lengths far off it to hold D."""
        motion = self.actuator_weights if reference.kind == "actuator" else None
        return schedule_gains(reference, self.params, self.weights, self.dt, self.gain_spacing, motion)

    def follow(self, reference: Reference, t_start: float, gains: ScheduledGains | None = None) -> None:
        """Track ``reference`` from the time ``t_start`` [s] on (gains designed here unless given)."""
        self.gains = gains if gains is not None else self.schedule(reference)
        self.reference = reference
        self.t_start = float(t_start)

    def hold(self, rho1: float, rho2: float, t: float = 0.0) -> None:
        """Hold rest at the actuator lengths ``(rho1, rho2)`` [m]."""
        self.follow(hold_reference(rho1, rho2, self.params), t)

    def hold_here(self, t: float) -> None:
        """Hold rest where the reference is at ``t`` (cancel: stop there). For an end-effector
        reference that is the IK solution of its D at ``t`` (its rho2 is the dynamic one, off
        the static solution while D accelerates); otherwise its lengths."""
        if self.reference is None:
            raise ParameterError("hold_here: no reference to stop on")
        s = self.reference.sample(t - self.t_start)
        rho = (float(s.q[0]), float(s.q[1]))
        if self.reference.kind == "end_effector":
            try:
                c = nearest_solution(float(s.end_effector[0]), float(s.end_effector[1]), rho, self.params)
                rho = (c.rho1, c.rho2)
            except TensegrityError:
                pass                     # keep the lengths: the reference's D stays reachable in practice
        self.hold(*rho, t)

    def done(self, t: float) -> bool:
        """True once ``t`` is past the reference's end."""
        return self.reference is not None and t - self.t_start >= self.reference.duration

    # -- one tick ---------------------------------------------------------------------
    def update(self, t: float, q: Vector, qdot: Vector) -> Tick:
        """The forces for the state ``(q, qdot)`` measured at ``t`` [s]; advances the integral."""
        ref, gains = self.reference, self.gains
        if ref is None or gains is None:
            raise ParameterError("update: no reference (call hold or follow first)")
        tau = t - self.t_start
        row = ref.packed(tau)
        u_ff = ref.packed(tau + 0.5 * self.dt)[6:8]
        L = self.params.L
        q0, q1, q2 = float(q[0]), float(q[1]), float(q[2])
        d = np.array([q0 + L * math.cos(q2) - row[8], L * math.sin(q2) - row[9]])
        e = np.empty(8)
        e[:3] = (q0 - row[0], q1 - row[1], q2 - row[2])
        e[3:6] = (float(qdot[0]) - row[3], float(qdot[1]) - row[4], float(qdot[2]) - row[5])
        e[6:] = self.z
        K = gains.at(tau)
        u = u_ff - K @ e
        f = np.clip(u, -self.max_force, self.max_force)
        h = self.dt if self._t_last is None else min(max(t - self._t_last, 0.0), 5.0 * self.dt)
        self._t_last = t
        if np.array_equal(f, u) and d[0] * d[0] + d[1] * d[1] < self.integral_band**2:
            self._integrate(d * h, K[:, 6:])
        return Tick(f, u, ReferenceSample(row[:3], row[3:6], u_ff, row[8:10]), d + row[8:10], tau)

    def _integrate(self, dz: NDArray[np.float64], Kz: NDArray[np.float64]) -> None:
        z = self.z + dz
        demand = float(np.max(np.abs(Kz @ z)))
        if demand > self.max_force:
            z *= self.max_force / demand
        self.z = z

    def reset_integral(self) -> None:
        self.z = np.zeros(2)
        self._t_last = None
