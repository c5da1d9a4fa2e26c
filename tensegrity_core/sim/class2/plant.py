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

- ``fold i``: ``rho_i`` falls through 0 (free actuator) -> impact law, then mode selection;
- ``release i``: the contact force of a held actuator falls through 0 (it would have to
  pull) -> the actuator is let go;
- ``singular``: lambda1 or lambda2 reaches ``SINGULAR_GUARD_REL L`` -> the simulation stops
  with an error (the coordinates break down there).

:class:`Class2Plant` is the frozen part (compiled once per scene); a :class:`Class2System`
is the plant in one contact mode under one set of input laws: what the stepping integrator
integrates between two restarts (:class:`~tensegrity_core.sim.stepper.OdeSystem`). An event
or a new command gives a new system; nothing is ever changed in place.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass

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
from tensegrity_core.sim.class2.contact import impact, select_mode
from tensegrity_core.sim.class2.setup import ForceEffect, class2_params
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.inputs import Law, next_breakpoint
from tensegrity_core.sim.scene import Scene
from tensegrity_core.sim.stepper import StateEvent

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Class2StateEvent:
    """A state event: ``g(t, y)`` crosses zero in ``direction`` (-1 falling, +1 rising)."""

    kind: EventKind      # "fold" | "release" | "singular"
    index: int           # actuator (0, 1) or 0/1 for lambda1/lambda2
    g: Callable[[float, FloatArray], float]
    direction: float = -1.0


def bits_of(mode: Iterable[int]) -> int:
    """The contact mode as bits (bit i: actuator i held)."""
    return sum(1 << i for i in mode)


def _fold_event(i: int) -> Class2StateEvent:
    """Free actuator ``i`` folds: its length falls through 0."""
    return Class2StateEvent("fold", i, lambda t, y: y[i])


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
        """Event functions in the system's mode."""
        L = self.plant.L
        lim = (SINGULAR_GUARD_REL * L) ** 2
        out = [Class2StateEvent("singular", 0, lambda t, y: (2 * L - y[0] - y[1]) * (2 * L + y[0] + y[1]) - lim),
               Class2StateEvent("singular", 1, lambda t, y: (L - y[0]) * (L + y[0]) - lim)]
        if self.plant.fold is not None:
            out += [self._release_event(i) if i in self.mode else _fold_event(i) for i in (0, 1)]
        return out

    def _release_event(self, i: int) -> Class2StateEvent:
        """Held actuator ``i`` lets go: its contact force falls through 0."""
        return Class2StateEvent("release", i, lambda t, y: self.accelerations(t, y)[1][i])

    def handle_event(self, event: StateEvent, t: float, y: ArrayLike) -> tuple[FloatArray, Class2System]:
        """Apply an event at ``(t, y)``: the state to restart from, and the system of the new mode."""
        y = np.array(y, dtype=float)
        if event.kind == "singular":
            name = ("lambda1", "lambda2")[event.index]
            where = ("rho1 + rho2 reached 2L (struts AE and CE flat)", "rho1 reached L (strut BF flat)")[event.index]
            raise SimulationError(f"t = {t:.9g} s: {where}: {name} = {SINGULAR_GUARD_REL:g} L, where the coordinates "
                                  f"(rho1, rho2, beta) break down; the simulation stops here "
                                  f"(state {np.array2string(y[:6], precision=6)})", t=t)
        if event.kind == "fold":
            mode = self._fold(event.index, t, y)
        else:
            mode = self._select(t, y, set(self.mode) - {event.index})
        return y, self.with_mode(mode)

    def after_step(self, t: float, y: FloatArray) -> None:
        """Nothing to re-chart for the class-2 coordinates."""
        return None

    def _fold(self, i: int, t: float, y: FloatArray) -> frozenset[int]:
        """Actuator ``i`` reaches zero length: impact, then the contact mode (``y`` updated in place)."""
        fold = self.plant.fold
        assert fold is not None               # fold events exist with the fold limit only
        y[i] = 0.0
        eom = self.plant.eom
        M = eom.inertia.mass_matrix(eom.kinematics(y.tolist()))
        qd, kept = impact(M, y[3:6], i, self.mode, fold.restitution)
        if abs(qd[i]) < fold.rest_velocity:
            qd[i] = 0.0
        y[3:6] = qd
        candidates = set(kept) | ({i} if qd[i] == 0.0 else set())
        return self._select(t, y, candidates)

    def _select(self, t: float, y: FloatArray, candidates: Collection[int]) -> frozenset[int]:
        """The contact mode among ``candidates`` (``y``'s held entries zeroed in place)."""
        def solve(S: Collection[int]) -> tuple[FloatArray, FloatArray]:
            return self.accelerations(t, y, S)
        a, lam = solve(candidates)
        tol = 1e-9 * (1.0 + float(np.abs(a).max()) + float(np.abs(lam).max()))
        mode, _, _ = select_mode(solve, candidates, tol)
        for j in mode:
            y[j] = 0.0
            y[3 + j] = 0.0
        return frozenset(mode)

    def resolve_contacts(self, t0: float, y0: ArrayLike) -> tuple[FloatArray, frozenset[int]]:
        """``(y, mode)`` after resolving the contacts of a starting state (impacts at ``t0``,
        then the contact mode); ``(y0, mode)`` without the fold limit."""
        y = np.array(y0, dtype=float)
        if self.plant.fold is None:
            return y, self.mode
        system = self
        for i in (0, 1):
            if y[i] == 0.0 and y[3 + i] < 0.0:
                system = system.with_mode(system._fold(i, t0, y))
        candidates = {i for i in (0, 1) if y[i] == 0.0 and y[3 + i] == 0.0} | set(system.mode)
        return y, system._select(t0, y, candidates)
