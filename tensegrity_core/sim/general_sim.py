"""General-structure scenes with inertia: set-up, the integrator, and what an observation reports.

Effects map to the model as follows: ``springs`` the members' elastic forces (required: they
are the structure), ``damping`` an axial damper on every taut member (``c`` or
``beta EA/l0``), ``gravity`` the weights of all lumped masses, ``loads`` the structure file's
loads plus the scene's (dead loads from ``t = 0``). Actuator members take their rest length
from the scene's inputs. The initial equilibrium is form-found under the springs, gravity
(if listed) and the initial state's ``preload``; the scene's loads act from ``t = 0`` on.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.formfind import form_find
from tensegrity_core.general.statics import potential_energy
from tensegrity_core.sim.backend import Integrated
from tensegrity_core.sim.errors import SceneError, SimulationError
from tensegrity_core.sim.general_model import GeneralModel, NodalMasses
from tensegrity_core.sim.inputs import HeldCommand, next_breakpoint


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


def runtime_laws(scene) -> list:
    """Rest-length laws of the actuator members (commanded inputs start at the drawn rest length)."""
    s = scene.model.structure
    laws = []
    for name in scene.inputs:
        law = scene.inputs[name]
        if law.law == "commanded":
            i = s.member_names.index(name)
            laws.append(HeldCommand(s.rest_lengths[i] if law.initial is None else law.initial))
        else:
            laws.append(law)
    return laws


def rest_lengths_function(scene, laws):
    """``t -> rest lengths (m,)`` with the actuators' laws, or None without actuators."""
    s = scene.model.structure
    act = np.asarray(scene.model.actuators, dtype=int)
    if not len(act):
        return None
    base = s.rest_lengths.copy()

    def rest_lengths(t):
        out = base.copy()
        out[act] = [law.value_at(t, 0.0) for law in laws]
        bad = np.flatnonzero(~(out[act] > 0))
        if bad.size:
            raise SimulationError(f"t = {t:.9g} s: rest length of actuator "
                                  f"{s.member_names[act[bad[0]]]!r} must be > 0, got {out[act[bad[0]]]!r}", t=t)
        return out

    return rest_lengths


def prepare_inputs(backend, scene) -> None:
    """Set ``structure``, ``laws`` and ``actuator_names`` of a general back end (and check that
    the members are simulated at all)."""
    if "springs" not in scene.effects:
        raise SceneError("a general structure needs 'springs' (its members' elastic forces)", key=("effects",))
    backend.scene = scene
    backend.structure = scene.model.structure
    backend.laws = runtime_laws(scene)
    backend.actuator_names = tuple(scene.inputs)


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


class GeneralDynamic(Integrated):
    """Back end: nodal / rigid-body dynamics of a general structure."""

    kind = "general"
    quasi_static = False
    positive = True

    def __init__(self, scene, *, t_end: float = math.inf):
        prepare_inputs(self, scene)
        s = self.structure
        config = initial_configuration(scene)
        x0 = coordinates(config)
        rest = rest_lengths_function(scene, self.laws)
        self.model = GeneralModel(s, masses=NodalMasses(s), damping=member_damping(scene),
                                  gravity=scene_gravity(scene), loads=scene_loads(scene), rest_lengths_of=rest,
                                  actuators=scene.model.actuators, x0=x0, R_ref=config.rotations)
        self.model.next_breakpoint = lambda t: next_breakpoint(self.laws, t, math.inf)
        method = scene.integrator.method
        self.method = "Radau" if method == "auto" else method
        self.start_stepper(np.concatenate([x0, np.zeros(len(x0))]), t_end=t_end)

    def sample(self) -> tuple:
        # the rotation chart may be re-anchored later: keep this sample's reference orientation
        return self.stepper.t, self.stepper.y.copy(), self.model.R_ref.copy()

    def record(self, times, out: list) -> None:
        self.stepper.record(times, out, lambda: self.model.R_ref.copy())

    def names(self) -> dict:
        s = self.structure
        return {"node_names": s.node_names, "member_names": s.member_names, "member_nodes": s.members}

    def observe(self, samples) -> dict:
        model = self.model
        n = model.n
        rows = {k: [] for k in ("t", "state", "q", "qdot", "applied_forces", "nodes", "member_lengths",
                                "member_forces", "potential_energy", "kinetic_energy")}
        twin = model.statics_twin(0.0)
        saved = model.R_ref
        try:
            for t, y, R_ref in samples:
                model.R_ref = R_ref
                x, v = y[:n], y[n:]
                coords, r, R = model.placement(x)
                vel = model.velocities(v, r)
                force, _, lengths, _ = model.member_state(t, coords, vel)
                if model.rest_lengths_of is not None:
                    twin = model.statics_twin(t)
                rows["t"].append(t)
                rows["state"].append(y)
                rows["q"].append(minimal_coordinates(model.lay, x, R))
                rows["qdot"].append(v)
                rows["applied_forces"].append(model.rest_lengths(t)[model.actuators])
                rows["nodes"].append(coords)
                rows["member_lengths"].append(lengths)
                rows["member_forces"].append(force)
                rows["potential_energy"].append(potential_energy(twin, coords))
                rows["kinetic_energy"].append(model.kinetic_energy(x, v))
        finally:
            model.R_ref = saved
        return finish_observations(rows, self.scene)



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
