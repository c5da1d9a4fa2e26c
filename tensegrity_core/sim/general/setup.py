"""Set-up shared by the general-structure back ends: what both compile alike (their base
:class:`GeneralBackEnd`), loads, weights, dampers, rest lengths, the initial equilibrium, and
the coordinates and observations of a configuration.

Effects map to the model as follows: ``springs`` the members' elastic forces (required: they
are the structure), ``damping`` an axial damper on every taut member (``c`` or
``beta EA/l0``), ``gravity`` the weights of all lumped masses, ``loads`` the structure file's
loads plus the scene's (dead loads from ``t = 0``). Actuator members take their rest length
from the scene's inputs. The initial equilibrium is form-found under the springs, gravity
(if listed) and the initial state's ``preload``; the scene's loads act from ``t = 0`` on.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.dofs import DofLayout
from tensegrity_core.general.formfind import form_find
from tensegrity_core.general.structure import Structure
from tensegrity_core.sim.commands import compile_inputs
from tensegrity_core.sim.errors import SceneError, SimulationError
from tensegrity_core.sim.inputs import Commanded, InputLaw, Law
from tensegrity_core.sim.model import Frozen, Interface, Names, Observed, ObservedArrays
from tensegrity_core.sim.scene import GeneralModelSpec, Scene

FloatArray = NDArray[np.float64]
#: The quantities both general back ends observe per sample (:func:`finish_observations` adds the
#: constant ones).
OBSERVED = ("t", "state", "q", "qdot", "applied_forces", "nodes", "member_lengths", "member_forces",
            "potential_energy", "kinetic_energy", "member_rest_lengths", "member_rates", "member_slack",
            "body_positions", "body_orientations", "body_velocities", "body_angular_velocities")


def general_model(scene: Scene) -> GeneralModelSpec:
    """The structure and its actuators of a general scene (the only scenes the general back ends take)."""
    model = scene.model
    if not isinstance(model, GeneralModelSpec):
        raise TypeError(f"a general back end compiles general scenes, not {model.kind} ones")
    return model


def scene_loads(scene: Scene) -> FloatArray | None:
    """(n, 3) dead loads [N] of the ``loads`` effect (structure's loads + the scene's), or None."""
    if "loads" not in scene.effects:
        return None
    structure = general_model(scene).structure
    loads: FloatArray = structure.loads.copy()
    for node, vec in scene.effects["loads"].forces.items():
        loads[node] += vec
    return loads


def scene_gravity(scene: Scene) -> FloatArray | None:
    """The ``gravity`` effect's field (3,) [m/s^2], or None."""
    return np.asarray(scene.effects["gravity"].vector, dtype=float) if "gravity" in scene.effects else None


def member_damping(scene: Scene) -> FloatArray | None:
    """(m,) axial damping coefficients [N s/m] of the ``damping`` effect, or None."""
    if "damping" not in scene.effects:
        return None
    d = scene.effects["damping"]
    s = general_model(scene).structure
    if d.c is not None:
        return np.full(s.n_members, d.c)
    assert d.beta is not None               # a general scene's damping gives c or beta
    c: FloatArray = d.beta * s.EA / s.rest_lengths
    return c


def static_structure(scene: Scene, *, loads: ArrayLike | None = None,
                     rest_lengths: ArrayLike | None = None) -> Structure:
    """The structure as the statics see it: the scene's gravity (if listed) on its masses, the
    given dead loads, the given rest lengths."""
    s = general_model(scene).structure
    g = scene_gravity(scene)
    return s.replace(gravity=np.zeros(3) if g is None else g,
                     loads=np.zeros((s.n_nodes, 3)) if loads is None else np.asarray(loads, dtype=float),
                     rest_lengths=s.rest_lengths if rest_lengths is None else np.asarray(rest_lengths, dtype=float))


def equilibrium(structure: Structure, x0: Configuration | None = None, *, what: str,
                t: float = 0.0) -> Configuration:
    """Form-find a stable equilibrium (restarting from ``x0``) or raise."""
    result = form_find(structure, x0=x0)
    if not result.success:
        raise SimulationError(f"t = {t:.9g} s: no stable equilibrium {what}: {result.message} "
                              f"(relative residual {result.residual:.3g}, norm {result.residual_norm:.3g} N)", t=t)
    config = result.configuration
    assert config is not None                # form_find's results carry their configuration
    return config


def drawn_rest_lengths(scene: Scene) -> FloatArray:
    """The actuators' drawn rest lengths [m] (the commanded inputs' values before a command)."""
    s = general_model(scene).structure
    return np.array([s.rest_lengths[s.member_names.index(name)] for name in scene.inputs])


class RestLengths:
    """``t -> rest lengths (m,)`` [m] of all members: the drawn ones, the actuators' from their
    input ``laws`` (which must keep them > 0)."""

    def __init__(self, structure: Structure, actuators: ArrayLike, laws: Iterable[Law]):
        self.structure = structure
        self.actuators = np.asarray(actuators, dtype=int)
        self.laws = tuple(laws)
        self.base = structure.rest_lengths.copy()

    def __call__(self, t: float) -> FloatArray:
        act = self.actuators
        out = self.base.copy()
        out[act] = [law.value_at(t, 0.0) for law in self.laws]
        bad = np.flatnonzero(~(out[act] > 0))
        if bad.size:
            raise SimulationError(f"t = {t:.9g} s: rest length of actuator "
                                  f"{self.structure.member_names[act[bad[0]]]!r} must be > 0 m, got "
                                  f"{out[act[bad[0]]]!r} m", t=t)
        return out


def rest_lengths_function(scene: Scene, laws: Iterable[Law]) -> RestLengths | None:
    """The members' rest lengths under the actuators' ``laws``, or None without actuators."""
    model = general_model(scene)
    if not len(model.actuators):
        return None
    return RestLengths(model.structure, model.actuators, laws)


def check_springs(scene: Scene) -> None:
    """A general structure is simulated through its members: the scene must list ``springs``."""
    if "springs" not in scene.effects:
        raise SceneError("a general structure needs 'springs' (its members' elastic forces)", key=("effects",))


def names_of(structure: Structure) -> Names:
    return Names(structure.node_names, structure.member_names, structure.members, structure.member_kinds,
                 structure.layout.body_names)


def general_interface(structure: Structure, actuators: Iterable[int], names: Iterable[str],
                      laws: Iterable[InputLaw]) -> Interface:
    """The inputs of a general model: rest lengths [m] of the actuator members, any value > 0."""
    laws = tuple(laws)
    return Interface("rest_length", tuple(names), tuple(isinstance(law, Commanded) for law in laws),
                     tuple((0.0, math.inf) for _ in laws), tuple(int(i) for i in actuators))


def quaternions(R: ArrayLike) -> FloatArray:
    """Unit quaternions ``(x, y, z, w)`` (k, 4) of rotation matrices ``R`` (k, 3, 3), with ``w >= 0``."""
    R = np.asarray(R, dtype=float).reshape(-1, 3, 3)
    if not len(R):
        return np.zeros((0, 4))
    quat: FloatArray = Rotation.from_matrix(R).as_quat()
    return np.where(quat[:, 3:] < 0.0, -quat, quat)


class GeneralBackEnd(Frozen):
    """The base of both general back ends: what they compile alike from a general scene that
    lists ``springs``. ``scene``; its ``structure``; the input ``laws`` and ``actuator_names``
    in input order with the ``initial_commands`` (commanded rest lengths [m] hold the drawn
    ones); the ``names`` of the nodes and members."""

    kind = "general"

    def __init__(self, scene: Scene):
        check_springs(scene)
        self.scene = scene
        self.structure = general_model(scene).structure
        self.laws, self.actuator_names, self.initial_commands = compile_inputs(scene.inputs, drawn_rest_lengths(scene))
        self.names = names_of(self.structure)
        self.interface = general_interface(self.structure, general_model(scene).actuators, self.actuator_names,
                                           self.laws)


def coordinates(config: Configuration) -> FloatArray:
    """The minimal coordinate ``U`` of a configuration with every body's rotation vector 0
    (free node coordinates and body centres)."""
    lay = config.structure.layout
    x = np.zeros(lay.n_dof)
    free = lay.free_index >= 0
    x[lay.free_index[free]] = config.coords[free]
    if lay.body_dof.size:
        x[lay.body_dof[:, None] + np.arange(3)[None, :]] = config.centres
    return x


def initial_configuration(scene: Scene) -> Configuration:
    """The configuration a general scene starts from (drawn, or the equilibrium with its preload)."""
    s = general_model(scene).structure
    if scene.initial.kind == "drawn":
        return Configuration.initial(s)
    preload = np.zeros((s.n_nodes, 3))
    for node, vec in scene.initial.preload.items():
        preload[node] += vec
    return equilibrium(static_structure(scene, loads=preload), what="for the initial state (springs, gravity, "
                       "preload)")


def minimal_coordinates(layout: DofLayout, x: ArrayLike, R: ArrayLike) -> FloatArray:
    """``q``: free node coordinates, body centres and body rotation vectors (from the drawing)."""
    q = np.array(x, dtype=float)
    if layout.body_dof.size:
        rot = layout.body_dof[:, None] + 3 + np.arange(3)[None, :]
        q[rot] = Rotation.from_matrix(R).as_rotvec()
    return q


def finish_observations(rows: Mapping[str, list[Any]], scene: Scene) -> ObservedArrays:
    """The observed arrays of sample ``rows`` (one list per quantity of :data:`OBSERVED`), with
    the quantities a general structure reports constant (end effector, no folds, no contacts)."""
    s = general_model(scene).structure
    N = len(rows["t"])
    m, nb = s.n_members, len(s.layout.moving_bodies)

    def floats(key: str, *shape: int) -> FloatArray:
        return np.array(rows[key], dtype=float).reshape(N, *shape)

    nodes = floats("nodes", s.n_nodes, 3)
    return ObservedArrays(
        t=floats("t"), state=floats("state", -1), q=floats("q", -1), qdot=floats("qdot", -1),
        applied_forces=floats("applied_forces", -1), contact_forces=np.zeros((N, 0)), nodes=nodes,
        member_lengths=floats("member_lengths", m), member_forces=floats("member_forces", m),
        end_effector=nodes[:, general_model(scene).end_effector].copy(),
        potential_energy=floats("potential_energy"), kinetic_energy=floats("kinetic_energy"),
        folded=np.zeros(N, dtype=bool), member_rest_lengths=floats("member_rest_lengths", m),
        member_rates=floats("member_rates", m),
        member_slack=np.array(rows["member_slack"], dtype=bool).reshape(N, m),
        body_positions=floats("body_positions", nb, 3), body_orientations=floats("body_orientations", nb, 4),
        body_velocities=floats("body_velocities", nb, 3),
        body_angular_velocities=floats("body_angular_velocities", nb, 3))


def first_observation(data: ObservedArrays) -> Observed:
    """The first sample of observed arrays, without the sample axis."""
    return Observed(
        t=float(data["t"][0]), state=data["state"][0], q=data["q"][0], qdot=data["qdot"][0],
        applied_forces=data["applied_forces"][0], contact_forces=data["contact_forces"][0], nodes=data["nodes"][0],
        member_lengths=data["member_lengths"][0], member_forces=data["member_forces"][0],
        end_effector=data["end_effector"][0], potential_energy=float(data["potential_energy"][0]),
        kinetic_energy=float(data["kinetic_energy"][0]), folded=bool(data["folded"][0]),
        member_rest_lengths=data["member_rest_lengths"][0], member_rates=data["member_rates"][0],
        member_slack=data["member_slack"][0], body_positions=data["body_positions"][0],
        body_orientations=data["body_orientations"][0], body_velocities=data["body_velocities"][0],
        body_angular_velocities=data["body_angular_velocities"][0])
