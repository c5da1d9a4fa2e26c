"""Set-up shared by the general-structure back ends: loads, weights, dampers, rest lengths,
the initial equilibrium, and the coordinates and observations of a configuration.

Effects map to the model as follows: ``springs`` the members' elastic forces (required: they
are the structure), ``damping`` an axial damper on every taut member (``c`` or
``beta EA/l0``), ``gravity`` the weights of all lumped masses, ``loads`` the structure file's
loads plus the scene's (dead loads from ``t = 0``). Actuator members take their rest length
from the scene's inputs. The initial equilibrium is form-found under the springs, gravity
(if listed) and the initial state's ``preload``; the scene's loads act from ``t = 0`` on.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.formfind import form_find
from tensegrity_core.sim.errors import SceneError, SimulationError
from tensegrity_core.sim.model import Names


def scene_loads(scene):
    """(n, 3) dead loads [N] of the ``loads`` effect (structure's loads + the scene's), or None."""
    if "loads" not in scene.effects:
        return None
    structure = scene.model.structure
    loads = structure.loads.copy()
    for node, vec in scene.effects["loads"].forces.items():
        loads[node] += vec
    return loads


def scene_gravity(scene):
    return np.asarray(scene.effects["gravity"].vector, dtype=float) if "gravity" in scene.effects else None


def member_damping(scene):
    """(m,) axial damping coefficients [N s/m] of the ``damping`` effect, or None."""
    if "damping" not in scene.effects:
        return None
    d = scene.effects["damping"]
    s = scene.model.structure
    if d.c is not None:
        return np.full(s.n_members, d.c)
    return d.beta * s.EA / s.rest_lengths


def static_structure(scene, *, loads=None, rest_lengths=None):
    """The structure as the statics see it: the scene's gravity (if listed) on its masses, the
    given dead loads, the given rest lengths."""
    s = scene.model.structure
    g = scene_gravity(scene)
    return s.replace(gravity=np.zeros(3) if g is None else g,
                     loads=np.zeros((s.n_nodes, 3)) if loads is None else np.asarray(loads, dtype=float),
                     rest_lengths=s.rest_lengths if rest_lengths is None else np.asarray(rest_lengths, dtype=float))


def equilibrium(structure, x0=None, *, what: str, t: float = 0.0) -> Configuration:
    """Form-find a stable equilibrium (restarting from ``x0``) or raise."""
    result = form_find(structure, x0=x0)
    if not result.success:
        raise SimulationError(f"t = {t:.9g} s: no stable equilibrium {what}: {result.message} "
                              f"(residual {result.residual:.3g} N)", t=t)
    return result.configuration


def drawn_rest_lengths(scene) -> np.ndarray:
    """The actuators' drawn rest lengths [m] (the commanded inputs' values before a command)."""
    s = scene.model.structure
    return np.array([s.rest_lengths[s.member_names.index(name)] for name in scene.inputs])


class RestLengths:
    """``t -> rest lengths (m,)`` [m] of all members: the drawn ones, the actuators' from their
    input ``laws`` (which must keep them > 0)."""

    def __init__(self, structure, actuators, laws):
        self.structure = structure
        self.actuators = np.asarray(actuators, dtype=int)
        self.laws = tuple(laws)
        self.base = structure.rest_lengths.copy()

    def __call__(self, t: float) -> np.ndarray:
        act = self.actuators
        out = self.base.copy()
        out[act] = [law.value_at(t, 0.0) for law in self.laws]
        bad = np.flatnonzero(~(out[act] > 0))
        if bad.size:
            raise SimulationError(f"t = {t:.9g} s: rest length of actuator "
                                  f"{self.structure.member_names[act[bad[0]]]!r} must be > 0, got "
                                  f"{out[act[bad[0]]]!r}", t=t)
        return out


def rest_lengths_function(scene, laws) -> RestLengths | None:
    """The members' rest lengths under the actuators' ``laws``, or None without actuators."""
    if not len(scene.model.actuators):
        return None
    return RestLengths(scene.model.structure, scene.model.actuators, laws)


def check_springs(scene) -> None:
    """A general structure is simulated through its members: the scene must list ``springs``."""
    if "springs" not in scene.effects:
        raise SceneError("a general structure needs 'springs' (its members' elastic forces)", key=("effects",))


def names_of(structure) -> Names:
    return Names(structure.node_names, structure.member_names, structure.members)


def coordinates(config) -> np.ndarray:
    """The minimal coordinate ``U`` of a configuration with every body's rotation vector 0
    (free node coordinates and body centres)."""
    lay = config.structure.layout
    x = np.zeros(lay.n_dof)
    free = lay.free_index >= 0
    x[lay.free_index[free]] = config.coords[free]
    if lay.body_dof.size:
        x[lay.body_dof[:, None] + np.arange(3)[None, :]] = config.centres
    return x


def initial_configuration(scene) -> Configuration:
    s = scene.model.structure
    if scene.initial.kind == "drawn":
        return Configuration.initial(s)
    preload = np.zeros((s.n_nodes, 3))
    for node, vec in scene.initial.preload.items():
        preload[node] += vec
    return equilibrium(static_structure(scene, loads=preload), what="for the initial state (springs, gravity, "
                       "preload)")


def minimal_coordinates(layout, x, R) -> np.ndarray:
    """``q``: free node coordinates, body centres and body rotation vectors (from the drawing)."""
    q = np.array(x, dtype=float)
    if layout.body_dof.size:
        rot = layout.body_dof[:, None] + 3 + np.arange(3)[None, :]
        q[rot] = Rotation.from_matrix(R).as_rotvec()
    return q


def finish_observations(rows: dict, scene) -> dict:
    data = {k: np.array(v, dtype=float) for k, v in rows.items()}
    N = len(data["t"])
    data["applied_forces"] = data["applied_forces"].reshape(N, -1)
    data["end_effector"] = data["nodes"][:, scene.model.end_effector].copy()
    data["folded"] = np.zeros(N, dtype=bool)
    data["contact_forces"] = np.zeros((N, 0))
    return data
