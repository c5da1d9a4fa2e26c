"""The class-2 mechanism with inertia: the kernel's equations of motion, the drive and the fold limit.

State ``y = (rho1, rho2, beta, rho1dot, rho2dot, betadot, [f1_lag, f2_lag], [e1, e2])``
(SI units; the bracketed actuator states exist with actuator lag / compliance, see
:mod:`tensegrity_core.class2.dynamics.drive`). The right-hand side is::

    M(q) qddot + C(q, qdot) = sum_effects Q_e(q, qdot) - (T1, T2, 0) [+ contact forces]

with the effects the scene lists composed by
:class:`~tensegrity_core.class2.dynamics.equations.EquationsOfMotion` (an effect the scene
does not list is not built and costs nothing). With the fold limit, the *contact mode*
(actuators held at zero length) selects the reduced solve of the kernel's
:class:`~tensegrity_core.class2.dynamics.inertia.Inertia`; events switch modes:

- ``fold i``: ``rho_i`` falls through 0 (free actuator; located at ``-PENETRATION_REL L``)
  -> the impact law on every actuator at zero length, then the contact mode;
- ``release i``: the contact force of a held actuator falls through 0 (it would have to
  pull; located at ``-RELEASE_REL`` of the force scale) -> the contact mode is chosen again;
- ``singular``: lambda1 or lambda2 reaches ``SINGULAR_GUARD_REL L`` -> the simulation stops
  with an error (the coordinates break down there).

Where the inputs change (a new command, a law's breakpoint) the contact mode is chosen
again too (:meth:`Class2System.resume`): a held actuator that a new force would make pull
is let go at once. The small margins make every event function strictly positive where a
system starts, so no crossing is ever missed for starting on its zero, and no event can
fire again at the instant its own change was made (see ``docs/design/scenes.md``, "The fold limit").

:class:`Class2Plant` is the frozen part (compiled once per scene); a :class:`Class2System`
is the plant in one contact mode under one set of input laws: what the stepping integrator
integrates between two restarts (:class:`~tensegrity_core.sim.stepper.OdeSystem`). An event
or a new command gives a new system; nothing is ever changed in place.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.dynamics.drive import Drive
from tensegrity_core.class2.dynamics.equations import EquationsOfMotion
from tensegrity_core.class2.dynamics.inertia import FREE
from tensegrity_core.class2.dynamics.kinematics import Kinematics, kinematics
from tensegrity_core.class2.dynamics.limits import SINGULAR_GUARD_REL
from tensegrity_core.class2.names import STATE_NAMES
from tensegrity_core.errors import TensegrityError
from tensegrity_core.events import EventKind
from tensegrity_core.sim.class2.contact import held_set, impact, stick
from tensegrity_core.sim.class2.setup import ForceEffect, class2_params
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.event_location import Crossing
from tensegrity_core.sim.inputs import Law, next_breakpoint
from tensegrity_core.sim.scene import Scene
from tensegrity_core.sim.stepper import Transition

FloatArray = NDArray[np.float64]


#: A free actuator's fold event fires where its length reaches ``-PENETRATION_REL L`` (then set
#: to 0): strictly below the zero that a lift-off leaves it at, so a crossing is never missed.
PENETRATION_REL: Final = 1e-12
#: Actuators within ``NEAR_REL L`` of zero length take part in an impact (and are set to 0):
#: simultaneous impacts are one impact, not a cascade of single ones.
NEAR_REL: Final = 1e-10
#: A held actuator's release fires where its contact force reaches ``-RELEASE_REL`` times the
#: force scale ``1 + |R1| + |R2|`` [N]: strictly below the ``lambda >= 0`` of the mode choice.
RELEASE_REL: Final = 1e-10
#: Half the time step [s, relative to ``1 + |t|``] of the central difference that gives a
#: release event's rate: its truncation error (``RATE_STEP^2`` relative over the motion's
#: time scale) and its rounding (``1e-16 / RATE_STEP`` of the force scale) both far below
#: what the dip test needs.
RATE_STEP: Final = 1e-6


@dataclass(frozen=True)
class Class2StateEvent:
    """A state event: ``value(t, y)`` crosses zero in ``direction`` (-1 falling, +1 rising);
    ``rate(t, y)`` is its time derivative when known; ``hard_stop``: ``value`` is the distance
    [m] to the fold limit's stop (a
    :class:`~tensegrity_core.sim.event_location.StateEvent` of one component)."""

    kind: EventKind      # "fold" | "release" | "singular"
    index: int           # actuator (0, 1) or 0/1 for lambda1/lambda2
    value: Callable[[float, FloatArray], float]
    rate: Callable[[float, FloatArray], float] | None = None
    direction: float = -1.0
    hard_stop: bool = False

    @property
    def indices(self) -> tuple[int]:
        return (self.index,)

    def g(self, t: float, y: FloatArray) -> float:
        return self.value(t, y)

    def values(self, t: float, y: FloatArray) -> tuple[float, float | None]:
        return self.value(t, y), None if self.rate is None else self.rate(t, y)


def bits_of(mode: Iterable[int]) -> int:
    """The contact mode as bits (bit i: actuator i held)."""
    return sum(1 << i for i in mode)


def _fold_event(i: int, L: float) -> Class2StateEvent:
    """Free actuator ``i`` folds: its length falls through ``-PENETRATION_REL L``."""
    margin = PENETRATION_REL * L
    return Class2StateEvent("fold", i, lambda t, y: y[i] + margin, lambda t, y: y[3 + i], hard_stop=True)


class Class2Plant:
    """Equations of motion of one scene: the listed ``effects`` (kernel effects), the drive and
    the fold limit. Frozen."""

    def __init__(self, scene: Scene, effects: Sequence[ForceEffect]):
        params = class2_params(scene)
        self.params = params
        self.L = params.L
        self.eom = EquationsOfMotion(params, effects)
        eff = scene.effects
        lag = eff.get("actuator_lag")
        comp = eff.get("actuator_compliance")
        self.drive = Drive(lag_tau=lag.tau if lag else None,
                           compliance=(comp.stiffness, comp.drive_damping) if comp else None)
        self.fold = eff.get("fold_limit")
        #: The smallest actuator length [m] the integration resolves: its position tolerance.
        self.resolution = scene.integrator.atol + scene.integrator.rtol * self.L
        self.n = 6 + self.drive.n_states
        self.state_names = STATE_NAMES + self.drive.state_names

    def system(self, mode: Iterable[int], laws: Iterable[Law]) -> Class2System:
        """The plant in contact ``mode`` (held actuators) under input ``laws``."""
        return Class2System(self, frozenset(mode), tuple(laws))

    def check_state(self, y: Sequence[float] | FloatArray) -> None:
        """Raise :class:`SimulationError` if ``y`` is not a state of the model's domain."""
        if len(y) != self.n:
            raise SimulationError(f"a state of this model has {self.n} entries ({', '.join(self.state_names)}), "
                                  f"got {len(y)}")
        if not all(math.isfinite(v) for v in y):
            raise SimulationError(f"state is not finite: {list(y)!r}")
        try:
            self.eom.kinematics(list(y))
        except TensegrityError as err:
            raise SimulationError(f"state outside the mechanism's domain: {err}") from None


class Class2System:
    """The plant in one contact mode under one set of input laws (an
    :class:`~tensegrity_core.sim.stepper.OdeSystem`). ``fun`` is built once per system with
    everything it reads bound as locals (the right-hand side costs a few microseconds)."""

    def __init__(self, plant: Class2Plant, mode: frozenset[int], laws: tuple[Law, ...]):
        self.plant = plant
        self.mode = mode
        self.laws = laws
        self.bits = bits_of(mode)
        self.drive = plant.drive.bind(laws)
        self.fun = self._right_hand_side()

    def with_mode(self, mode: Iterable[int]) -> Class2System:
        return Class2System(self.plant, frozenset(mode), self.laws)

    def with_laws(self, laws: Iterable[Law]) -> Class2System:
        return Class2System(self.plant, self.mode, tuple(laws))

    def next_breakpoint(self, t: float) -> float:
        return next_breakpoint(self.laws, t, math.inf)

    # -- right-hand side ------------------------------------------------------------------
    def _right_hand_side(self) -> Callable[[float, FloatArray], FloatArray]:
        eom = self.plant.eom
        L, limit, forces, inertia = eom.L, eom.limit, eom.forces, eom.inertia
        transmitted, rates, bits = self.drive.forces, self.drive.rates, self.bits
        solve: Callable[[Kinematics[float], float, float, float], tuple[float, ...]]
        if bits == FREE:
            solve = inertia.solve_free
        else:
            def solve(k: Kinematics[float], Q1: float, Q2: float, Q3: float) -> tuple[float, ...]:
                return inertia.solve(k, Q1, Q2, Q3, bits)[:3]
        fun: Callable[[float, FloatArray], FloatArray]
        if len(forces) == 1:
            (force,) = forces

            def fun(t: float, y: FloatArray) -> FloatArray:
                yl = y.tolist()
                k = kinematics(L, yl, limit)
                Q1, Q2, Q3 = force(k)
                T1, T2 = transmitted(t, yl)
                return np.array((yl[3], yl[4], yl[5]) + solve(k, Q1 - T1, Q2 - T2, Q3) + rates(t, yl))
        else:
            def fun(t: float, y: FloatArray) -> FloatArray:
                yl = y.tolist()
                k = kinematics(L, yl, limit)
                Q1 = Q2 = Q3 = 0.0
                for force in forces:
                    a, b, c = force(k)
                    Q1 += a
                    Q2 += b
                    Q3 += c
                T1, T2 = transmitted(t, yl)
                return np.array((yl[3], yl[4], yl[5]) + solve(k, Q1 - T1, Q2 - T2, Q3) + rates(t, yl))
        return fun

    def generalized_force(self, t: float,
                          y: Sequence[float] | FloatArray) -> tuple[Kinematics[float], tuple[float, float, float]]:
        """``(k, (Q1 - T1, Q2 - T2, Q3))``: the context and every generalised force except
        inertia and contact."""
        yl = list(y)
        eom = self.plant.eom
        k = eom.kinematics(yl)
        Q1, Q2, Q3 = eom.generalized_force(k)
        T1, T2 = self.drive.forces(t, yl)
        return k, (Q1 - T1, Q2 - T2, Q3)

    def accelerations(self, t: float, y: Sequence[float] | FloatArray,
                      mode: Collection[int] | None = None) -> tuple[FloatArray, FloatArray]:
        """``(qddot (3,), contact forces (2,))`` at ``(t, y)`` in ``mode`` (default: the system's)."""
        bits = self.bits if mode is None else bits_of(mode)
        k, (R1, R2, R3) = self.generalized_force(t, y)
        a1, a2, a3, l1, l2 = self.plant.eom.inertia.solve(k, R1, R2, R3, bits)
        return np.array((a1, a2, a3)), np.array((l1, l2))

    # -- Jacobian -----------------------------------------------------------------------------
    def jac(self, t: float, y: ArrayLike) -> FloatArray:
        """Analytic ``d(dy/dt)/dy`` in the system's mode, from the kernel's derivatives."""
        state = np.asarray(y, dtype=float)
        plant = self.plant
        a, _ = self.accelerations(t, state)
        k = plant.eom.kinematics(state.tolist())
        dT, extra = plant.drive.jacobian(t, state, self.laws)
        free = [i for i in range(3) if i not in self.mode]
        n = plant.n
        J = np.zeros((n, n))
        J[0:3, 3:6] = np.eye(3)
        J[[3 + i for i in free]] = plant.eom.acceleration_jacobian(k, a, dT, free)
        J[6:] = extra
        return J

    # -- events ---------------------------------------------------------------------------------
    def events(self) -> list[Class2StateEvent]:
        """Class2StateEvent functions in the system's mode."""
        L = self.plant.L
        lim = (SINGULAR_GUARD_REL * L) ** 2
        out = [Class2StateEvent("singular", 0, lambda t, y: (2 * L - y[0] - y[1]) * (2 * L + y[0] + y[1]) - lim),
               Class2StateEvent("singular", 1, lambda t, y: (L - y[0]) * (L + y[0]) - lim)]
        if self.plant.fold is not None:
            out += [self._release_event(i) if i in self.mode else _fold_event(i, L) for i in (0, 1)]
        return out

    def _release_event(self, i: int) -> Class2StateEvent:
        """Held actuator ``i`` lets go: its contact force falls through ``-RELEASE_REL`` of the
        force scale.

        Its rate [N/s] is the central difference of that value along the motion over
        ``RATE_STEP`` either side: with it the stepper sees a contact force that dips below
        zero and comes back inside one step (held, the mechanism is smooth and steps long:
        the force can pass through zero and back between two step ends). The rate only
        chooses where to look; the crossing is located on the value itself."""
        solve = self.plant.eom.inertia.solve
        bits = self.bits
        fun = self.fun

        def value(t: float, y: FloatArray) -> float:
            k, (R1, R2, R3) = self.generalized_force(t, y)
            lam = solve(k, R1, R2, R3, bits)[3 + i]
            return float(lam) + RELEASE_REL * (1.0 + abs(R1) + abs(R2))

        def rate(t: float, y: FloatArray) -> float:
            h = RATE_STEP * (1.0 + abs(t))
            dy = h * fun(t, y)
            return (value(t + h, y + dy) - value(t - h, y - dy)) / (2.0 * h)
        return Class2StateEvent("release", i, value, rate)

    def handle_event(self, crossing: Crossing, y: ArrayLike) -> Transition[Class2System]:
        """Apply an event located at ``crossing.t`` where the state is ``y``: the state to restart
        from, the system of the new contact mode and the events to log."""
        y = np.array(y, dtype=float)
        t = crossing.t
        if crossing.kind == "singular":
            name = ("lambda1", "lambda2")[crossing.index]
            where = ("rho1 + rho2 reached 2L (struts AE and CE flat)", "rho1 reached L (strut BF flat)")[crossing.index]
            raise SimulationError(f"t = {t:.9g} s: {where}: {name} = {SINGULAR_GUARD_REL:g} L, where the coordinates "
                                  f"(rho1, rho2, beta) break down; the simulation stops here "
                                  f"(state {np.array2string(y[:6], precision=6)})", t=t)
        if crossing.kind == "fold":
            # Located at rho_i = -PENETRATION_REL L, applied at rho_i = 0 with the speed it had
            # there, v0^2 = v^2 + 2 a_i delta: setting the length back without that would give
            # each bounce the stop's work over delta, which sustains micro-bounces forever.
            i = crossing.index
            a, _ = self.accelerations(t, y)
            y[3 + i] = -math.sqrt(max(0.0, y[3 + i] ** 2 + 2.0 * float(a[i]) * PENETRATION_REL * self.plant.L))
            y[i] = 0.0
            return self._contacts(t, y, reach=NEAR_REL * self.plant.L)
        return self._contacts(t, y)

    def after_step(self, t: float, y: FloatArray) -> None:
        """Nothing to re-chart for the class-2 coordinates."""
        return None

    def resume(self, t: float, y: FloatArray) -> Transition[Class2System]:
        """Under this system's (new) input laws at ``(t, y)``: the contact mode chosen again --
        a held actuator that would now have to pull is let go."""
        return self._contacts(t, np.array(y, dtype=float))

    def _contacts(self, t: float, y: FloatArray, *, reach: float = 0.0) -> Transition[Class2System]:
        """Impacts and contact mode at ``(t, y)`` (``y`` is changed in place): the actuators held
        or within ``reach`` of zero length (an impact: ``NEAR_REL L``; otherwise those at zero)
        are set to zero; if any approaches, all of them take the impact law's impulses; those
        slower than the rest velocity stick; then the complementarity problem chooses
        which of those at rest stay held. Logs ``fold`` for each actuator hit (or newly held)
        and ``release`` for each let go."""
        fold = self.plant.fold
        if fold is None:
            return Transition(y, self)
        near = [j for j in (0, 1) if j in self.mode or y[j] <= reach]
        if not near:
            return Transition(y, self)
        y[near] = 0.0
        eom = self.plant.eom
        Minv = np.linalg.inv(eom.inertia.mass_matrix(eom.kinematics(y.tolist())))
        qd = y[3:6].copy()
        hit = [j for j in near if qd[j] < 0.0]
        if hit:
            qd, _ = impact(Minv, qd, near, fold.restitution)
        y[3:6] = qd
        # a bounce lower than the integration resolves (its flight's apex v^2 / 2|a| under the
        # position tolerance) is at rest: its flight would be integration noise, and the noise
        # can feed such bounces for ever (a Zeno fixed point above rest_velocity)
        pressing, _ = self.accelerations(t, y, ())
        rest = max([fold.rest_velocity] + [math.sqrt(2.0 * max(0.0, -float(pressing[j])) * self.plant.resolution)
                                           for j in near])
        qd = stick(Minv, qd, near, rest)
        y[3:6] = qd
        a_free, _ = self.accelerations(t, y, ())
        held = held_set(Minv, a_free, [j for j in near if qd[j] == 0.0])
        log: list[tuple[EventKind, int]] = [("fold", j) for j in near if j in hit or (j in held and j not in self.mode)]
        log += [("release", j) for j in sorted(self.mode - held)]
        return Transition(y, self.with_mode(held), tuple(log))

    def resolve_contacts(self, t0: float, y0: ArrayLike) -> tuple[FloatArray, frozenset[int]]:
        """``(y, mode)`` after resolving the contacts of a starting state (impacts at ``t0``,
        then the contact mode); ``(y0, mode)`` without the fold limit."""
        transition = self._contacts(t0, np.array(y0, dtype=float))
        return transition.y, transition.system.mode
