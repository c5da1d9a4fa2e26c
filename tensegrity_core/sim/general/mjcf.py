"""The MJCF writer of the general dynamics: a MuJoCo model with the physics of :mod:`.model`.

:func:`write_mjcf` turns a general scene with inertia into an MJCF document that MuJoCo
simulates with the equations of :mod:`tensegrity_core.sim.general.model` (reached through
:func:`tensegrity_core.export.export_mjcf`, which checks the options). Written with
``xml.etree`` only: MuJoCo is never imported. Every MJCF name is ``<kind>:<the project's name>``, so names never collide (with
each other or with MuJoCo's ``world``) and a reader finds each element by the name it has
in the structure:

=========================  ==================================================================
project                    MJCF
=========================  ==================================================================
free node ``n``            body ``node:n`` at its initial position, a slide joint
                           ``node:n:x|y|z`` per free axis (pinned axes have none), a point
                           mass (the lumped mass; its nominal rotational inertia enters no
                           equation), site ``node:n``
pinned node ``n``          world site ``node:n`` (so are the nodes of a fixed rigid body)
moving rigid body ``b``    body ``body:b`` with free joint ``body:b``; frame origin at the
                           centroid of its nodes, axes of the reference drawing (``pos``,
                           ``quat`` its initial pose); ``inertial``: the lumped masses' total,
                           centre of mass and full inertia tensor; site ``node:k`` per node
string ``s``               spatial tendon ``member:s``, stiffness ``EA/l0``,
                           ``springlength="0 l0"``: MuJoCo's dead band, tension only
bar ``s``                  spatial tendon ``member:s``, stiffness ``EA/l0``,
                           ``springlength="l0"``: tension and compression
actuator member ``a``      tendon ``member:a`` and actuator ``member:a`` with the exact force
                           ``-EA (l - l0)/l0`` for ``ctrl = 1 - l0_ref/l0`` (below)
damping ``c_i``            tendon ``damping`` (acts on slack strings too: docs/mujoco.md)
gravity                    ``<option gravity>`` on the lumped masses (zero when not listed)
dead load on node ``n``    actuator ``load:n``: a constant force (gain 0, affine bias
                           ``|F|``) at site ``node:n`` along ``gear`` = ``F/|F|`` in the
                           frame of the world site ``world:origin`` (``refsite``)
initial state              bodies placed at it (``qpos0``), and keyframe ``initial``
                           (``qpos``, zero ``qvel``, the actuator members' ``ctrl``)
=========================  ==================================================================

**Actuator members** are bars whose rest length ``l0`` is a control input. MuJoCo's actuator
force is ``gain * ctrl + bias`` with gain and bias affine in the tendon length ``l``; with
``k_ref = EA / l0_ref`` (``l0_ref`` the drawn rest length), gain ``k_ref l`` and bias
``EA - k_ref l``, the force is ``EA - k_ref l (1 - ctrl)``, which is ``-EA (l - l0)/l0`` --
the member's tension, pulling -- exactly when ``ctrl = 1 - l0_ref / l0`` (dimensionless;
0 at the drawn rest length, about the relative change of rest length for small changes,
below 1 for every ``l0 > 0``). No affine form has the rest length itself as ``ctrl``.

**Options**: contacts off (``<flag contact="disable">``, and there are no geoms);
``inertiafromgeom="false"``; ``alignfree="false"`` (a free body's frame stays at its node
centroid, so its ``qpos`` is the general dynamics' centre and orientation). The integrator
is RK4 by default; the default time step comes from the fastest rate of the linearised
dynamics (:mod:`tensegrity_core.export.timestep`).

**What MuJoCo cannot take** is refused in one line (:mod:`tensegrity_core.export.mujoco_limits`):
a free node's lumped mass below ``mjMINVAL`` (1e-15 kg), a rigid body's mass below it or an
eigenvalue of its inertia tensor below ``mjEPS`` (1e-14 kg m^2), a fastest rate the
eigenvalue solver cannot find in double precision (without a given step). A rigid body whose
centre of mass lies within MuJoCo's 1e-6 m pose tolerance of its node centroid, without being
at it, has its frame at its centre of mass (MuJoCo would put it at the frame).

**Inertia tensors** are written with ``1e-12`` of their trace added on the diagonal: a body
whose masses lie in a plane sits exactly on MuJoCo's bound ``A + B >= C`` on the principal
moments, which rounding would otherwise break about a third of the time. A relative change
of 1e-12 is far below any integrator's error.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.linalg import ArpackNoConvergence
from scipy.spatial.transform import Rotation

from tensegrity_core.export.errors import ExportError
from tensegrity_core.export.mjcf_text import number, vector
from tensegrity_core.export.model import MjcfModel
from tensegrity_core.export.mujoco_limits import MJEPS, MJMINVAL, MJMINVAL_MARGIN, MJMINVAL_WHY, frame_shift
from tensegrity_core.export.timestep import default_timestep, fastest_rate
from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.mass_properties import body_inertias, mass_matrix
from tensegrity_core.general.statics import equilibrium_matrix
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure
from tensegrity_core.sim.commands import compile_inputs
from tensegrity_core.sim.general.model import NodalMasses
from tensegrity_core.sim.general.setup import (
    check_springs,
    drawn_rest_lengths,
    initial_configuration,
    member_damping,
    rest_lengths_function,
    scene_gravity,
    scene_loads,
    static_structure,
)
from tensegrity_core.sim.inputs import held
from tensegrity_core.sim.scene import GeneralModelSpec, Scene

FloatArray = NDArray[np.float64]

#: The isotropic part added to every rigid body's inertia tensor, relative to its trace.
INERTIA_MARGIN = 1e-12
#: The world site that dead loads take their direction from.
LOAD_FRAME = "world:origin"
AXES = "xyz"


def write_mjcf(scene: Scene, timestep: float | None, integrator: str) -> MjcfModel:
    """The MJCF model of a general scene with inertia (options checked by the caller)."""
    check_springs(scene)
    return _Writer(scene, timestep, integrator).model()


class _Writer:
    """One export: the scene's physics gathered once, then written element by element."""

    def __init__(self, scene: Scene, timestep: float | None, integrator: str):
        model = scene.model
        assert isinstance(model, GeneralModelSpec)        # export_mjcf checked it
        self.scene = scene
        s = self.structure = model.structure
        self.source = model.source
        self.lay = s.layout
        self.config = initial_configuration(scene)
        self.masses = NodalMasses(s).node
        self.bodies = body_inertias(s, self.masses)
        g = scene_gravity(scene)
        self.gravity = np.zeros(3) if g is None else g
        loads = scene_loads(scene)
        self.loads = np.zeros((s.n_nodes, 3)) if loads is None else loads
        self.damping = member_damping(scene)
        self.actuators = model.actuators
        laws, _, commands = compile_inputs(scene.inputs, drawn_rest_lengths(scene))
        rest = rest_lengths_function(scene, held(laws, commands))
        self.rest_lengths: FloatArray = s.rest_lengths.copy() if rest is None else rest(0.0)
        self._check_masses()
        self.rate = self._fastest_rate()
        if timestep is None and not (math.isfinite(self.rate) and self.rate > 0):
            raise ExportError(f"scene {scene.name!r}: the fastest rate of its linearised dynamics is "
                              f"{self.rate:g} 1/s in double precision, so no time step follows from it: give one "
                              f"(timestep=..., --timestep)")
        self.timestep = default_timestep(self.rate) if timestep is None else float(timestep)
        self.integrator = integrator
        self.qpos: list[float] = []
        self.ctrl: list[float] = []

    def _check_masses(self) -> None:
        """What MuJoCo cannot take (:mod:`tensegrity_core.export.mujoco_limits`): a free node's
        mass below ``mjMINVAL``, a moving body's mass below it or an eigenvalue of its inertia
        tensor (with :data:`INERTIA_MARGIN`) below ``mjEPS``."""
        s, lay = self.structure, self.lay
        for i in np.flatnonzero(~lay.fixed_mask.all(axis=1) & (lay.node_body < 0)):
            if not self.masses[i] >= MJMINVAL:
                raise ExportError(f"{self.scene.name!r}: node {s.node_names[i]!r} has a mass of "
                                  f"{self.masses[i]:.3g} kg; {MJMINVAL_WHY}")
        for slot, b in enumerate(self.bodies):
            least = float(np.linalg.eigvalsh(b.inertia + INERTIA_MARGIN * float(np.trace(b.inertia)) * np.eye(3))[0])
            if not (b.mass >= MJMINVAL and least >= MJEPS * (1.0 + MJMINVAL_MARGIN)):
                raise ExportError(f"{self.scene.name!r}: rigid body {lay.body_names[slot]!r} has a mass of "
                                  f"{b.mass:.3g} kg and a least principal inertia of {least:.3g} kg m^2; MuJoCo "
                                  f"refuses a moving body's mass below its mjMINVAL, {MJMINVAL:g} kg, and a full "
                                  f"inertia tensor's eigenvalue below its mjEPS, {MJEPS:g} kg m^2")

    def _fastest_rate(self) -> float:
        """The bound of :func:`~tensegrity_core.export.timestep.fastest_rate` at the initial
        state, slack strings counted as taut (they may tighten); nan where the eigenvalue
        solver finds none in double precision."""
        twin = static_structure(self.scene, loads=self.loads, rest_lengths=self.rest_lengths)
        config = Configuration(twin, self.config.coords, self.config.centres, self.config.rotations)
        K = tangent_stiffness(twin, config, sparse=True, slack_elastic=True)
        D = None
        if self.damping is not None:
            A = equilibrium_matrix(twin, config, sparse=True)
            D = A @ sp.diags(self.damping) @ A.T
        M = mass_matrix(self.structure, self.masses, self.config)
        try:
            return fastest_rate(M, K, D)
        except (np.linalg.LinAlgError, scipy.linalg.LinAlgError, ArpackNoConvergence):
            return math.nan

    # -- the document ----------------------------------------------------------------------------
    def model(self) -> MjcfModel:
        s, lay = self.structure, self.lay
        root = ET.Element("mujoco", model=self.scene.name)
        root.append(ET.Comment(
            f" tensegrity export mjcf: {self.scene.name} ({self.scene.source or self.source or 'in memory'})."
            f" The physics of the project's general dynamics; what MuJoCo does differently: docs/mujoco.md."
            f" Actuator members: ctrl = 1 - l0_ref/l0 (l0 their rest length). "))
        ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false", alignfree="false",
                      autolimits="true")
        option = ET.SubElement(root, "option", timestep=number(self.timestep), integrator=self.integrator,
                               gravity=vector(self.gravity))
        ET.SubElement(option, "flag", contact="disable")
        self._defaults(root)
        world = ET.SubElement(root, "worldbody")
        fixed = lay.fixed_mask.all(axis=1) & (lay.node_body < 0)
        for i in np.flatnonzero(fixed):
            ET.SubElement(world, "site", name=_node(s, int(i)), pos=vector(self.config.coords[i]))
        if self._loaded_nodes().size:
            ET.SubElement(world, "site", name=LOAD_FRAME, pos="0 0 0")
        node_bodies = np.flatnonzero(~lay.fixed_mask.all(axis=1) & (lay.node_body < 0))
        for i in node_bodies:
            self._node_body(world, int(i))
        for slot in range(len(lay.moving_bodies)):
            self._rigid_body(world, slot)
        self._tendons(root)
        n_loads = self._actuators(root)
        keyframe = ET.SubElement(ET.SubElement(root, "keyframe"), "key", name="initial", qpos=vector(self.qpos),
                                 qvel=vector(np.zeros(lay.n_dof)))
        if self.ctrl:
            keyframe.set("ctrl", vector(self.ctrl))
        ET.indent(root, space="  ")
        xml = ET.tostring(root, encoding="unicode") + "\n"
        return MjcfModel(name=self.scene.name, xml=xml, timestep=self.timestep, integrator=self.integrator,
                         fastest_rate=self.rate, node_bodies=len(node_bodies), rigid_bodies=len(lay.moving_bodies),
                         tendons=s.n_members, loads=n_loads, actuator_members=len(self.actuators),
                         nq=len(self.qpos), nv=lay.n_dof)

    def _defaults(self, root: ET.Element) -> None:
        """Sizes for the viewer (a hundredth of the structure's extent) and a colour per member kind."""
        extent = float(np.ptp(self.config.coords, axis=0).max()) or 1.0
        default = ET.SubElement(root, "default")
        ET.SubElement(default, "site", size=number(0.01 * extent), rgba="0.2 0.2 0.2 1")
        colours = {"string": "0.85 0.3 0.1 1", "bar": "0.3 0.4 0.6 1", "actuator": "0.2 0.6 0.3 1"}
        widths = {"string": 0.002, "bar": 0.006, "actuator": 0.006}
        for kind in ("string", "bar", "actuator"):
            ET.SubElement(ET.SubElement(default, "default", {"class": kind}), "tendon",
                          width=number(widths[kind] * extent), rgba=colours[kind])

    def _node_body(self, world: ET.Element, i: int) -> None:
        s, lay = self.structure, self.lay
        m = float(self.masses[i])
        body = ET.SubElement(world, "body", name=_node(s, i), pos=vector(self.config.coords[i]))
        for axis in range(3):
            if not lay.fixed_mask[i, axis]:
                ET.SubElement(body, "joint", name=f"{_node(s, i)}:{AXES[axis]}", type="slide",
                              axis=vector(np.eye(3)[axis]))
                self.qpos.append(0.0)
        ET.SubElement(body, "inertial", pos="0 0 0", mass=number(m), diaginertia=vector([m, m, m]))
        ET.SubElement(body, "site", name=_node(s, i))

    def _rigid_body(self, world: ET.Element, slot: int) -> None:
        s, lay = self.structure, self.lay
        name = f"body:{lay.body_names[slot]}"
        b = self.bodies[slot]
        nodes = lay.body_nodes[slot]
        shift = frame_shift(b.com, lay.offsets[nodes], f"{self.scene.name!r}: rigid body {lay.body_names[slot]!r}",
                            float(np.abs(self.config.coords[nodes]).max()))
        R = self.config.rotations[slot]
        origin = self.config.centres[slot] + R @ shift
        quat = Rotation.from_matrix(R).as_quat(scalar_first=True)
        body = ET.SubElement(world, "body", name=name, pos=vector(origin), quat=vector(quat))
        ET.SubElement(body, "freejoint", name=name)
        self.qpos.extend([*origin, *quat])
        I = b.inertia + INERTIA_MARGIN * float(np.trace(b.inertia)) * np.eye(3)
        ET.SubElement(body, "inertial", pos=vector(b.com - shift), mass=number(b.mass),
                      fullinertia=vector([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
        for i in nodes:
            ET.SubElement(body, "site", name=_node(s, int(i)), pos=vector(lay.offsets[i] - shift))

    def _tendons(self, root: ET.Element) -> None:
        s = self.structure
        tendons = ET.SubElement(root, "tendon")
        for i, (a, b) in enumerate(s.members):
            kind = s.member_kinds[i]
            k = s.EA[i] / s.rest_lengths[i]
            attrs = {"name": f"member:{s.member_names[i]}", "class": kind}
            if kind == "string":
                attrs.update(stiffness=number(k), springlength=f"0 {number(s.rest_lengths[i])}")
            elif kind == "bar":
                attrs.update(stiffness=number(k), springlength=number(s.rest_lengths[i]))
            if self.damping is not None and self.damping[i] > 0:
                attrs["damping"] = number(self.damping[i])
            tendon = ET.SubElement(tendons, "spatial", attrs)
            ET.SubElement(tendon, "site", site=_node(s, int(a)))
            ET.SubElement(tendon, "site", site=_node(s, int(b)))

    def _loaded_nodes(self) -> NDArray[np.int64]:
        """Nodes with a dead load that can move (a load on a pinned node does no work)."""
        return np.flatnonzero(np.any(self.loads != 0, axis=1) & ~self.lay.fixed_mask.all(axis=1))

    def _actuators(self, root: ET.Element) -> int:
        """The actuator members' and the dead loads' actuators; returns the number of loads."""
        s = self.structure
        loaded = self._loaded_nodes()
        if not (len(self.actuators) or loaded.size):
            return 0
        actuators = ET.SubElement(root, "actuator")
        for i in self.actuators:
            name = f"member:{s.member_names[i]}"
            k_ref = s.EA[i] / s.rest_lengths[i]
            ET.SubElement(actuators, "general", name=name, tendon=name, gaintype="affine",
                          gainprm=f"0 {number(k_ref)} 0", biastype="affine",
                          biasprm=f"{number(s.EA[i])} {number(-k_ref)} 0")
            self.ctrl.append(1.0 - float(s.rest_lengths[i] / self.rest_lengths[i]))
        for i in loaded:
            force = self.loads[i]
            size = float(np.linalg.norm(force))
            ET.SubElement(actuators, "general", name=f"load:{s.node_names[i]}", site=_node(s, int(i)),
                          refsite=LOAD_FRAME, gear=vector([*(force / size), 0.0, 0.0, 0.0]), gainprm="0",
                          biastype="affine", biasprm=f"{number(size)} 0 0")
            self.ctrl.append(0.0)
        return int(loaded.size)


def _node(structure: Structure, i: int) -> str:
    return f"node:{structure.node_names[i]}"
