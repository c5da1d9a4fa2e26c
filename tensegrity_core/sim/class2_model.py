"""The class-2 mechanism with inertia: equations of motion composed from the listed effects.

State ``y = (rho1, rho2, beta, rho1dot, rho2dot, betadot, [f1_lag, f2_lag], [e1, e2])``
(SI units; the bracketed actuator states exist with actuator lag / compliance, see
:mod:`.class2_drive`). The right-hand side is::

    M(q) qddot + C(q, qdot) = sum_effects Q_e(q, qdot) - (T1, T2, 0) [+ contact forces]

where the tuple of effect callables (springs, damping, gravity, loads) was fixed when the
model was built: an effect the scene does not list is not in the tuple and costs nothing.
With the fold limit, the *contact mode* (actuators held at zero length) selects the reduced
solve of :class:`~tensegrity_core.sim.class2_inertia.Inertia`; events switch modes:

- ``fold i``: ``rho_i`` falls through 0 (free actuator) -> impact law, then mode selection;
- ``release i``: the contact force of a held actuator falls through 0 (it would have to
  pull) -> the actuator is let go;
- ``singular``: lambda1 or lambda2 reaches ``1e-3 L`` -> the simulation stops with an error
  (the coordinates break down there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tensegrity_core.errors import TensegrityError
from tensegrity_core.sim import class2_effects as fx
from tensegrity_core.sim.class2_drive import Drive
from tensegrity_core.sim.class2_inertia import Inertia
from tensegrity_core.sim.contact import impact, select_mode
from tensegrity_core.sim.errors import SimulationError

#: The singularity guard fires when lambda1 or lambda2 falls to this fraction of L.
GUARD_MARGIN = 1e-3


@dataclass(frozen=True)
class Event:
    """A state event: ``g(t, y)`` crosses zero in ``direction`` (-1 falling, +1 rising)."""

    kind: str            # "fold" | "release" | "singular"
    index: int           # actuator (0, 1) or 0/1 for lambda1/lambda2
    g: object
    direction: float = -1.0


def build_force_effects(scene, params) -> tuple:
    """The generalised-force effects the scene lists, in composition order."""
    eff = scene.effects
    out = []
    if "springs" in eff:
        out.append(fx.Springs(params))
    if "damping" in eff:
        out.append(fx.Damping(params))
    if "gravity" in eff:
        out.append(fx.Gravity(params, eff["gravity"].vector))
    if "loads" in eff:
        out.append(fx.Loads(params, eff["loads"].forces))
    return tuple(out)


class Class2Model:
    """Equations of motion of one scene; ``mode`` is the set of held actuators."""

    kind = "class2"

    def __init__(self, scene, laws):
        params = scene.model.params
        self.params = params
        self.L = params.L
        self.inertia = Inertia(params)
        self.effects = build_force_effects(scene, params)
        self._forces = tuple(e.force for e in self.effects)
        eff = scene.effects
        lag = eff.get("actuator_lag")
        comp = eff.get("actuator_compliance")
        self.drive = Drive(laws, lag_tau=lag.tau if lag else None,
                           compliance=(comp.stiffness, comp.drive_damping) if comp else None)
        self.fold = eff.get("fold_limit")
        self.n = 6 + self.drive.n_states
        self.state_names = ("rho1", "rho2", "beta", "rho1_dot", "rho2_dot", "beta_dot") + self.drive.state_names
        self.mode = frozenset()
        self._bits = 0
        self._drive_forces = self.drive.forces
        self._rates = self.drive.rates
        self._solve = self.inertia.solve

    # -- right-hand side ------------------------------------------------------------------
    def set_mode(self, mode) -> None:
        self.mode = frozenset(mode)
        self._bits = sum(1 << i for i in self.mode)

    def fun(self, t, y):
        """``dy/dt`` in the current contact mode (the integrator's right-hand side)."""
        yl = y.tolist()
        k = fx.context(self.L, yl)
        Q1 = Q2 = Q3 = 0.0
        for force in self._forces:
            a, b, c = force(k)
            Q1 += a
            Q2 += b
            Q3 += c
        T1, T2 = self._drive_forces(t, yl)
        a1, a2, a3, _, _ = self._solve(k, Q1 - T1, Q2 - T2, Q3, self._bits)
        return np.array((yl[3], yl[4], yl[5], a1, a2, a3) + tuple(self._rates(t, yl)))

    def generalized_force(self, t, y) -> tuple:
        """``(Q1 - T1, Q2 - T2, Q3)``: every generalised force except inertia and contact."""
        yl = list(y)
        k = fx.context(self.L, yl)
        Q = [0.0, 0.0, 0.0]
        for force in self._forces:
            for i, v in enumerate(force(k)):
                Q[i] += v
        T1, T2 = self._drive_forces(t, yl)
        return k, (Q[0] - T1, Q[1] - T2, Q[2])

    def accelerations(self, t, y, mode=None) -> tuple:
        """``(qddot (3,), contact forces (2,))`` at ``(t, y)`` in ``mode`` (default: current)."""
        bits = self._bits if mode is None else sum(1 << i for i in mode)
        k, (R1, R2, R3) = self.generalized_force(t, y)
        a1, a2, a3, l1, l2 = self._solve(k, R1, R2, R3, bits)
        return np.array((a1, a2, a3)), np.array((l1, l2))

    # -- Jacobian -----------------------------------------------------------------------------
    def jac(self, t, y) -> np.ndarray:
        """Analytic ``d(dy/dt)/dy`` in the current mode, from the effects' own derivatives."""
        y = np.asarray(y, dtype=float)
        q, qd = y[:3], y[3:6]
        a, _ = self.accelerations(t, y)
        k = fx.context(self.L, y.tolist())
        dQ_dq = np.zeros((3, 3))
        dQ_dqd = np.zeros((3, 3))
        for e in self.effects:
            A, B = e.jacobian(q, qd)
            dQ_dq += A
            dQ_dqd += B
        dMa, dC_dq, dC_dqd = self.inertia.jacobian_terms(k, a)
        dT, extra = self.drive.jacobian(t, y)
        n = self.n
        dR = np.zeros((3, n))
        dR[:, :3] = dQ_dq - dC_dq - dMa
        dR[:, 3:6] = dQ_dqd - dC_dqd
        dR[:2] -= dT
        free = [i for i in range(3) if i not in self.mode]
        M = self.inertia.mass_matrix(k)
        J = np.zeros((n, n))
        J[0:3, 3:6] = np.eye(3)
        J[[3 + i for i in free]] = np.linalg.solve(M[np.ix_(free, free)], dR[free])
        J[6:] = extra
        return J

    # -- events ---------------------------------------------------------------------------------
    def events(self) -> list:
        """Event functions for the current mode."""
        L = self.L
        lim = (GUARD_MARGIN * L) ** 2
        out = [Event("singular", 0, lambda t, y: (2 * L - y[0] - y[1]) * (2 * L + y[0] + y[1]) - lim),
               Event("singular", 1, lambda t, y: (L - y[0]) * (L + y[0]) - lim)]
        if self.fold is not None:
            for i in (0, 1):
                if i in self.mode:
                    out.append(Event("release", i, lambda t, y, i=i: self.accelerations(t, y)[1][i]))
                else:
                    out.append(Event("fold", i, lambda t, y, i=i: y[i]))
        return out

    def handle_event(self, event: Event, t: float, y) -> np.ndarray:
        """Apply an event at ``(t, y)``; returns the state to restart from (mode updated)."""
        y = np.array(y, dtype=float)
        if event.kind == "singular":
            name = ("lambda1", "lambda2")[event.index]
            where = ("rho1 + rho2 reached 2L (struts AE and CE flat)", "rho1 reached L (strut BF flat)")[event.index]
            raise SimulationError(f"t = {t:.9g} s: {where}: {name} = {GUARD_MARGIN:g} L, where the coordinates "
                                  f"(rho1, rho2, beta) break down; the simulation stops here "
                                  f"(state {np.array2string(y[:6], precision=6)})", t=t)
        if event.kind == "fold":
            return self._fold(event.index, t, y)
        return self._release(event.index, t, y)

    def _fold(self, i: int, t: float, y) -> np.ndarray:
        y[i] = 0.0
        k = fx.context(self.L, y.tolist())
        M = self.inertia.mass_matrix(k)
        qd, kept = impact(M, y[3:6], i, self.mode, self.fold.restitution)
        if abs(qd[i]) < self.fold.rest_velocity:
            qd[i] = 0.0
        y[3:6] = qd
        candidates = set(kept) | ({i} if qd[i] == 0.0 else set())
        self._select(t, y, candidates)
        return y

    def _release(self, i: int, t: float, y) -> np.ndarray:
        self._select(t, y, set(self.mode) - {i})
        return y

    def _select(self, t: float, y, candidates) -> None:
        def solve(S):
            return self.accelerations(t, y, S)
        a, lam = solve(candidates)
        tol = 1e-9 * (1.0 + float(np.abs(a).max()) + float(np.abs(lam).max()))
        mode, _, _ = select_mode(solve, candidates, tol)
        for j in mode:
            y[j] = 0.0
            y[3 + j] = 0.0
        self.set_mode(mode)

    def initial_state(self, t0: float, y0) -> np.ndarray:
        """Resolve contacts in the initial state (impacts at t0, then the contact mode)."""
        y = np.array(y0, dtype=float)
        if self.fold is None:
            return y
        for i in (0, 1):
            if y[i] == 0.0 and y[3 + i] < 0.0:
                y = self._fold(i, t0, y)
        candidates = {i for i in (0, 1) if y[i] == 0.0 and y[3 + i] == 0.0} | set(self.mode)
        self._select(t0, y, candidates)
        return y

    def after_step(self, t, y):
        """Nothing to re-chart for the class-2 coordinates."""
        return None

    def check_state(self, y) -> None:
        """Raise :class:`SimulationError` if ``y`` is outside the model's domain."""
        try:
            fx.context(self.L, list(y))
        except TensegrityError as err:
            raise SimulationError(f"state outside the mechanism's domain: {err}") from None
        if not all(math.isfinite(v) for v in y):
            raise SimulationError(f"state is not finite: {y!r}")
