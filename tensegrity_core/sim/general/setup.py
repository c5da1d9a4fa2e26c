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
from tensegrity_core.sim.inputs import Law
from tensegrity_core.sim.model import Names
from tensegrity_core.sim.scene import GeneralModelSpec, Scene

FloatArray = NDArray[np.float64]
#: The quantities both general back ends observe (:func:`finish_observations` adds the constant ones).
OBSERVED = ("t", "state", "q", "qdot", "applied_forces", "nodes", "member_lengths", "member_forces",
            "potential_energy", "kinetic_energy")


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
                                  f"{self.structure.member_names[act[bad[0]]]!r} must be > 0, got "
                                  f"{out[act[bad[0]]]!r}", t=t)
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
    return Names(structure.node_names, structure.member_names, structure.members)


class GeneralBackEnd:
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


def finish_observations(rows: Mapping[str, list[Any]], scene: Scene) -> dict[str, NDArray[Any]]:
    """The observed arrays of sample ``rows`` (one list per quantity), with the quantities a
    general structure reports constant (end effector, no folds, no contacts)."""
    data: dict[str, NDArray[Any]] = {k: np.array(v, dtype=float) for k, v in rows.items()}
    N = len(data["t"])
    data["applied_forces"] = data["applied_forces"].reshape(N, -1)
    data["end_effector"] = data["nodes"][:, general_model(scene).end_effector].copy()
    data["folded"] = np.zeros(N, dtype=bool)
    data["contact_forces"] = np.zeros((N, 0))
    return data
