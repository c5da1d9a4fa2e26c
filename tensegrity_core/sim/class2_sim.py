"""Class-2 scenes with inertia: initial state, run-time inputs, and the dynamic back end.

:class:`Class2Dynamic` is the simulator's back end for a class-2 scene that lists
``inertia``: a :class:`~tensegrity_core.sim.class2_model.Class2Model` integrated by a
:class:`~tensegrity_core.sim.stepper.Stepper`; a
:class:`~tensegrity_core.sim.class2_observe.Class2Observer` turns its states into the
observed quantities.
"""

from __future__ import annotations

import math

import numpy as np

from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.geometry import MEMBERS
from tensegrity_core.sim import class2_effects as fx
from tensegrity_core.sim.class2_model import Class2Model, build_force_effects
from tensegrity_core.sim.class2_observe import Class2Observer
from tensegrity_core.sim.backend import Integrated
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.inputs import HeldCommand, next_breakpoint

MEMBER_NAMES = tuple(m.name for m in MEMBERS)
MEMBER_NODES = np.array([m.nodes for m in MEMBERS])


def generalized_static_force(effects, L: float, q) -> np.ndarray:
    """Sum of the listed effects' generalised forces at ``q`` at rest (3,)."""
    k = fx.context(L, (q[0], q[1], q[2], 0.0, 0.0, 0.0))
    Q = np.zeros(3)
    for e in effects:
        Q += e.force(k)
    return Q


def equilibrium_angle(effects, params, rho1: float, rho2: float) -> float:
    """The stable ``beta`` for locked actuators under the springs and gravity (the scene's
    loads act from ``t = 0`` on, they are not part of the initial equilibrium).

    Starts at the springs' closed-form minimum (:func:`equilibrium_beta`) and runs Newton on
    ``Q3(beta) = 0`` when gravity also acts on beta."""
    beta = float(equilibrium_beta(rho1, rho2, params))
    conservative = [e for e in effects if e.name in ("springs", "gravity")]
    if not any(e.name == "gravity" for e in conservative):
        return beta
    zero = np.zeros(3)
    for _ in range(50):
        q = np.array([rho1, rho2, beta])
        Q3 = generalized_static_force(conservative, params.L, q)[2]
        K = -sum(e.jacobian(q, zero)[0] for e in conservative)[2, 2]
        if K <= 0:
            raise SceneError(f"no stable equilibrium angle beta near {beta:.6g} rad for rho1 = {rho1:g} m, "
                             f"rho2 = {rho2:g} m under the springs and gravity (d2V/dbeta2 = {K:.3g} <= 0: the "
                             f"springs cannot hold the struts' weight)", key=("initial",))
        step = Q3 / K
        beta += step
        if abs(step) < 1e-14:
            return beta
    raise SceneError(f"the equilibrium angle for rho1 = {rho1:g} m, rho2 = {rho2:g} m did not converge",
                     key=("initial",))


def initial_configuration(scene, effects) -> tuple:
    """``(q0, qdot0)`` of a class-2 scene."""
    init = scene.initial
    params = scene.model.params
    if init.kind == "state":
        return np.array(init.q, dtype=float), np.array(init.qdot, dtype=float)
    r1, r2 = init.lengths
    return np.array([r1, r2, equilibrium_angle(effects, params, r1, r2)]), np.zeros(3)


def runtime_laws(scene, hold) -> list:
    """Input laws, with commanded inputs turned into :class:`HeldCommand` (``hold``: the
    values that keep the initial state at rest)."""
    laws = []
    for i, name in enumerate(scene.inputs):
        law = scene.inputs[name]
        if law.law == "commanded":
            laws.append(HeldCommand(hold[i] if law.initial is None else law.initial))
        else:
            laws.append(law)
    return laws


class Class2Dynamic(Integrated):
    """Back end: the class-2 equations of motion with the scene's effects."""

    kind = "class2"
    quasi_static = False

    def __init__(self, scene, *, t_end: float = math.inf):
        params = scene.model.params
        self.scene = scene
        self.params = params
        effects = build_force_effects(scene, params)
        q0, qd0 = initial_configuration(scene, effects)
        hold = generalized_static_force(effects, params.L, q0)[:2]
        self.laws = runtime_laws(scene, hold)
        self.actuator_names = tuple(scene.inputs)
        self.model = Class2Model(scene, self.laws)
        self.observer = Class2Observer(scene, self.model.effects, inertia=True)
        self.model.next_breakpoint = lambda t: next_breakpoint(self.laws, t, math.inf)
        y0 = np.concatenate([q0, qd0, self.model.drive.initial_states(0.0, q0)])
        self.model.check_state(y0)
        y0 = self.model.initial_state(0.0, y0)
        method = scene.integrator.method
        if method == "auto":
            method = "Radau" if "actuator_compliance" in scene.effects else "DOP853"
        self.method = method
        self.start_stepper(y0, t_end=t_end)

    def sample(self) -> tuple:
        """What an observation needs at the current time: ``(t, y, mode bits, T (2,))``."""
        st = self.stepper
        y = st.y
        T = self.model.drive.forces(st.t, y.tolist())
        return st.t, y.copy(), self.model._bits, T

    def record(self, times, out: list) -> None:
        """Append samples at increasing ``times`` to ``out``."""
        states: list = []
        try:
            self.stepper.record(times, states, lambda: self.model._bits)
        finally:
            forces = self.model.drive.forces
            out.extend((t, y, bits, forces(t, y.tolist())) for t, y, bits in states)

    def observe(self, samples) -> dict:
        """Observed quantities of recorded samples ``[(t, y, mode bits, T), ...]`` (arrays)."""
        return self.observer.many([s[0] for s in samples], [s[1] for s in samples], [s[2] for s in samples],
                                  [s[3] for s in samples])

    def observe_now(self) -> dict:
        """The observation at the current time (one sample)."""
        return self.observer.one(*self.sample())
