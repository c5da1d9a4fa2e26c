"""Set-up shared by the class-2 back ends: the listed force effects, the initial configuration
and the names of what they observe.

Both back ends (with inertia, :mod:`.dynamic`; without, :mod:`.quasistatic`) build the
effects a scene lists from the physics kernel :mod:`tensegrity_core.class2.dynamics` and
start from the same configuration: the scene's state, or the equilibrium for the given
actuator lengths (springs and gravity; loads act from ``t = 0`` on).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.dynamics.effects import Damping, Gravity, Loads, Springs
from tensegrity_core.class2.dynamics.kinematics import Kinematics, kinematics
from tensegrity_core.class2.dynamics.limits import LAMBDA_MIN_REL
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.geometry import MEMBERS, NODE_NAMES
from tensegrity_core.class2.params import Class2Params
from tensegrity_core.class2.singularities.distances import dynamics_singularity
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.inputs import Commanded, InputLaw
from tensegrity_core.sim.model import Interface, Names
from tensegrity_core.sim.scene import Class2ModelSpec, Scene

FloatArray = NDArray[np.float64]
#: A generalised-force effect of the kernel.
ForceEffect = Springs | Damping | Gravity | Loads
#: An effect with a potential (every one but damping).
ConservativeEffect = Springs | Gravity | Loads

#: What a class-2 observation names: the six nodes and the ten members (MEMBERS order).
NAMES = Names(NODE_NAMES, tuple(m.name for m in MEMBERS), np.array([m.nodes for m in MEMBERS]),
              tuple(m.kind for m in MEMBERS))
#: The member each input drives: f1 the actuator AB, f2 the actuator BC.
INPUT_MEMBERS = {"f1": 0, "f2": 1}


def class2_interface(names: Sequence[str], laws: Sequence[InputLaw]) -> Interface:
    """The inputs of a class-2 model: actuator forces [N] (tension positive), any finite value."""
    return Interface("force", tuple(names), tuple(isinstance(law, Commanded) for law in laws),
                     tuple((-math.inf, math.inf) for _ in names), tuple(INPUT_MEMBERS[n] for n in names))


def singular_distance(params: Class2Params, q: Sequence[float] | FloatArray) -> tuple[str, float]:
    """``(name, lambda / L)`` of the singular set nearest the lengths ``q[:2]`` (the nearer of
    lambda1 and lambda2, :func:`~tensegrity_core.class2.singularities.dynamics_singularity`)."""
    return dynamics_singularity(float(q[0]), float(q[1]), params)


def class2_params(scene: Scene) -> Class2Params:
    """The mechanism's parameters of a class-2 scene (the only scenes the class-2 back ends take)."""
    model = scene.model
    if not isinstance(model, Class2ModelSpec):
        raise TypeError(f"a class-2 back end compiles class-2 scenes, not {model.kind} ones")
    return model.params


def force_effects(scene: Scene) -> tuple[ForceEffect, ...]:
    """The generalised-force effects the scene lists, in composition order (springs, damping,
    gravity, loads); an effect the scene does not list is not built."""
    params = class2_params(scene)
    eff = scene.effects
    out: list[ForceEffect] = []
    if "springs" in eff:
        out.append(Springs(params))
    if "damping" in eff:
        out.append(Damping(params))
    if "gravity" in eff:
        out.append(Gravity(params, eff["gravity"].vector))
    if "loads" in eff:
        out.append(Loads(params, eff["loads"].forces))
    return tuple(out)


def conservative(effects: Iterable[ForceEffect]) -> tuple[ConservativeEffect, ...]:
    """The effects with a potential among ``effects`` (all but damping, which a scene without
    inertia cannot list): what the total potential of the quasi-static model composes."""
    return tuple(e for e in effects if not isinstance(e, Damping))


def rest_context(L: float, q: Sequence[float] | FloatArray) -> Kinematics[Any]:
    """The kinematic context of configuration ``q`` at rest."""
    return kinematics(L, (q[0], q[1], q[2], 0.0, 0.0, 0.0), LAMBDA_MIN_REL * L)


def static_force(effects: Iterable[ForceEffect], L: float, q: Sequence[float] | FloatArray) -> FloatArray:
    """Sum of the effects' generalised forces at ``q`` at rest (3,); its first two entries are
    the actuator forces that hold ``q`` at rest."""
    k = rest_context(L, q)
    Q = np.zeros(3)
    for e in effects:
        Q += e.force(k)
    return Q


def equilibrium_angle(effects: Iterable[ForceEffect], params: Class2Params, rho1: float, rho2: float) -> float:
    """The stable ``beta`` for locked actuators under the springs and gravity (the scene's
    loads act from ``t = 0`` on, they are not part of the initial equilibrium).

    Starts at the springs' closed-form minimum (:func:`equilibrium_beta`) and runs Newton on
    ``Q3(beta) = 0`` when gravity also acts on beta."""
    beta = float(equilibrium_beta(rho1, rho2, params))
    acting = [e for e in effects if e.name in ("springs", "gravity")]
    if not any(e.name == "gravity" for e in acting):
        return beta
    for _ in range(50):
        q = (rho1, rho2, beta)
        k = rest_context(params.L, q)
        Q3 = float(static_force(acting, params.L, q)[2])
        K = -sum(float(e.jacobian(k)[0][2, 2]) for e in acting)
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


def initial_configuration(scene: Scene, effects: Iterable[ForceEffect]) -> tuple[FloatArray, FloatArray]:
    """``(q0, qdot0)`` of a class-2 scene."""
    init = scene.initial
    params = class2_params(scene)
    if init.kind == "state":
        return np.array(init.q, dtype=float), np.array(init.qdot, dtype=float)
    assert init.lengths is not None           # an "equilibrium" initial state of a class-2 scene
    r1, r2 = init.lengths
    return np.array([r1, r2, equilibrium_angle(effects, params, r1, r2)]), np.zeros(3)
