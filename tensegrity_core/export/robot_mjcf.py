"""The MJCF writer of tensegrity robots: a MuJoCo model of a :class:`~tensegrity_core.robot.description.Robot`.

:func:`write_robot_mjcf` turns a robot description into an MJCF document, and
:func:`write_robot_scene` a robot scene (its effects and initial lift applied to its robot;
the ``robot/dynamic`` back end's writer); both are reached through
:func:`tensegrity_core.export.export_mjcf`, which checks the options. Written with
``xml.etree`` only: MuJoCo is never imported. Every MJCF name is ``<kind>:<the robot's name>``:

=========================  ==================================================================
robot                      MJCF
=========================  ==================================================================
rod ``r``                  body ``rod:r`` with free joint ``rod:r``, frame at the rod's centre
                           with z along the rod (:func:`~tensegrity_core.robot.rod.rod_frames`,
                           the principal axes: what ``alignfree`` would pick); ``inertial``:
                           its mass and ``diaginertia (I_t, I_t, I_a)`` with the point masses
                           on its caps (:func:`rod_inertial`); a capsule geom (the rod, drawn
                           only; none at radius 0) and a sphere geom ``cap:n`` per end cap
                           (the contact sphere); sites ``node:n`` at the cap centres
rigid body ``b``           body ``body:b`` with free joint (a fixed body: world sites), its
                           lumped masses' inertia as the general dynamics have it
point mass on node ``n``   body ``node:n`` on slide joints ``node:n:x|y|z``
pinned node ``n``          world site ``node:n``
passive cable ``c``        spatial tendon ``cable:c``, ``stiffness`` k, ``springlength="0 l0"``
                           (tension only), ``damping`` c (acts on slack cables too)
actuated cable ``c``       spatial tendon ``cable:c`` and actuator ``cable:c`` by the motor's
                           mode (:mod:`.robot_motors`): a position actuator on the rest
                           length, an integrator of the reel speed, or a force actuator
                           pulling with the commanded tension; ``forcerange="-T_max 0"``
                           (tension only, the tension limit)
floor                      plane geom ``floor``; one contact pair ``contact:n`` per end cap
                           (``condim`` 3, elliptic cones; 6 with rolling or torsional
                           friction), parameters below
sensors                    ``length:c`` (``tendonpos``) per cable with a length sensor;
                           ``tension:c`` (``actuatorfrc``, minus the tension) per actuated
                           cable with a tension sensor; per IMU a site ``imu:x`` at the body's
                           centre, its axes the world's in the drawing (the project's body
                           frame, in which its IMU reads), with ``imu:x:orientation``
                           (``framequat``), ``imu:x:gyro``, ``imu:x:accelerometer`` (specific
                           force)
initial state              bodies as drawn (``qpos0``) and keyframe ``initial`` (``qpos``,
                           zero ``qvel``, ``ctrl`` and ``act`` each motor held as drawn; a
                           scene's ``ctrl`` its commands at t = 0)
=========================  ==================================================================

**What MuJoCo cannot take** is refused in one line (:class:`ExportError`;
:mod:`.mujoco_limits`): a moving body's mass or principal inertia below ``mjMINVAL``, a rigid
body's full inertia tensor with an eigenvalue below ``mjEPS``, a node nearer its body's frame
than 1e-6 m without being at it. A centre of mass that near its body's reference point gets
the body's frame (:func:`~.mujoco_limits.frame_shift`): MuJoCo would otherwise put it at the
frame.

**Motors** (:mod:`.robot_motors`). In the rest-length and reel-speed modes the actuator's
force is ``-(k (l - l0) + c ldot)`` with its activation as the rest length ``l0``, clipped
to ``[-T_max, 0]``: minus the cable law ``clip(k (l - l0) + c ldot, 0, T_max)`` while the
cable is taut (tendon force positive lengthens); a slack cable lengthening fast enough that
``c ldot > k (l0 - l)`` pulls in MuJoCo and not in the project. Not exported: the slew limit
of the rest-length and tension modes (MuJoCo's activations have no rate limit) and the
pay-out past ``T_max`` (MuJoCo clips the force, the rest length stays).

**Contact** (derived in docs/mujoco.md, "Robots"). With a constant impedance ``d``
(``solimp="d d ..."``) and direct ``solref="-S -D"``, MuJoCo's normal contact force on a body
of inverse weight ``A`` (``1/m`` for a free rod) at penetration ``delta`` is
``m S delta + m D deltadot + d F``, ``F`` the other forces pressing it into the floor: a
spring ``m S``, a damper ``m D`` and a share ``d`` of the load carried rigidly. It rests at
``delta = (1 - d) F / (m S)``, which is the Hunt-Crossley rest ``F / k`` for
``S = (1 - d) k A``. A linear damper cannot follow Hunt-Crossley's restitution, which falls
with the impact speed ``v`` (``e^2 ~ 1 - 4 dissipation v / 3``) to zero above
``3 / (4 dissipation)`` (0.15 m/s for the shipped robots, slower than a robot landing on a
face): ``D = 2 sqrt(S)`` damps the contact critically, so it does not bounce either.
Friction: one coefficient, ``mu_static``; the floor's ``torsional_friction`` and
``rolling_friction`` [m] are MuJoCo's torsional and rolling coefficients (``condim="6"``:
``friction="mu mu torsional rolling rolling"``), the same limits ``b F_n`` of the resisting
couples (MuJoCo's soft constraint regularises them where the project uses a spin rate,
:mod:`tensegrity_core.robot.contact`).
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.export.errors import ExportError
from tensegrity_core.export.mjcf_text import number, vector
from tensegrity_core.export.model import MjcfModel
from tensegrity_core.export.mujoco_limits import MJEPS, MJMINVAL, MJMINVAL_MARGIN, MJMINVAL_WHY, frame_shift
from tensegrity_core.export.robot_motors import CTRL_MEANING, motor_actuators
from tensegrity_core.general.mass_properties import layout_inertias
from tensegrity_core.robot.description import Floor, Robot
from tensegrity_core.robot.layout import bodies_layout
from tensegrity_core.robot.rod import rod_frames
from tensegrity_core.sim.inputs import Commanded
from tensegrity_core.sim.scene import RobotModelSpec, Scene
from tensegrity_core.sim.scene.spec import ContactSpec, FrictionSpec, GravitySpec, MotorsSpec

FloatArray = NDArray[np.float64]

#: MuJoCo's time step [s] unless one is given: the robots' 1 kHz loop.
DEFAULT_TIMESTEP = 1e-3
#: The contacts' constant impedance ``d`` (``solimp``): the share of the load the contact
#: carries rigidly; ``1 - d`` scales the contact's speed by ``sqrt(1 - d)`` (module docstring).
CONTACT_IMPEDANCE = 0.5
#: MuJoCo's ``impratio``: friction rows this many times stiffer than the normal, so a cap
#: loaded below its friction limit creeps slowly (MuJoCo's friction has no stiction anchor).
FRICTION_IMPRATIO = 100.0
#: The isotropic part added to a rigid body's inertia tensor, relative to its trace (see
#: :mod:`tensegrity_core.sim.general.mjcf`).
INERTIA_MARGIN = 1e-12


def write_robot_mjcf(robot: Robot, timestep: float | None, integrator: str, *, lift: float = 0.0,
                     name: str | None = None, commands: dict[str, float] | None = None) -> MjcfModel:
    """The MJCF model of ``robot`` (options checked by the caller), raised ``lift`` [m] above
    its drawing along the floor's normal, named ``name`` (default: the robot's), the keyframe's
    ``ctrl`` of each motor named in ``commands`` (by cable) that command in its mode's unit (the
    others held as drawn); raises :class:`ExportError` for what MJCF cannot hold (a pinned rod
    end, a point mass on a rod end)."""
    return _RobotWriter(robot, DEFAULT_TIMESTEP if timestep is None else timestep, integrator, lift,
                        name or robot.name, commands or {}).model()


def write_robot_scene(scene: Scene, timestep: float | None, integrator: str) -> MjcfModel:
    """The MJCF model of a robot scene (the writer of the ``robot/dynamic`` back end): its
    robot with the scene's effects -- gravity only if listed, the floor's contact only with
    ``contact`` (its stiffness and dissipation), friction only with ``friction`` (its static
    coefficient; frictionless otherwise), the motors' overrides -- raised by the initial
    ``lift``, stepping at the scene's own fixed step unless ``timestep`` [s] is given (the
    project integrates the scene with RK4 at ``integrator.max_step``: with ``integrator``
    RK4, MuJoCo integrates it the same way). The keyframe's ``ctrl`` holds each motor's
    command at t = 0 (a constant input's value, a law's or gait's first, a commanded input's
    ``initial``; as drawn without one), its activation the drawn state, as the project starts;
    inputs that change in time are not in the file: drive ``ctrl`` from them
    (``tests.mujoco_peer.play_gait``)."""
    model = scene.model
    assert isinstance(model, RobotModelSpec)            # export_mjcf picked this writer for it
    robot = model.robot
    fx = scene.effects
    gravity, motors = fx.get("gravity"), fx.get("motors")
    floor = scene_floor(scene)
    m = robot.motors
    if isinstance(motors, MotorsSpec):
        m = dataclasses.replace(m, **{key: np.full(len(m), value) for key in ("tau", "max_speed", "max_tension")
                                      if (value := getattr(motors, key)) is not None})
        modes = m.mode.copy()
        by_cable = {robot.cables.names[int(cable)]: j for j, cable in enumerate(m.cable)}
        for cable, mode in motors.modes:
            modes[by_cable[cable]] = mode
        m = dataclasses.replace(m, mode=modes)
    g = np.zeros(3) if not isinstance(gravity, GravitySpec) else np.asarray(gravity.vector, dtype=float)
    scene_robot = dataclasses.replace(robot, floor=floor, motors=m, gravity=g)
    step = scene.integrator.max_step if timestep is None else timestep
    return write_robot_mjcf(scene_robot, step, integrator, lift=scene.initial.lift, name=scene.name,
                            commands=initial_commands(scene))


def initial_commands(scene: Scene) -> dict[str, float]:
    """Each motor input's command at t = 0 by cable name, in its mode's unit: a law's value
    (at the cable's drawn length), a commanded input's ``initial``; none for a commanded
    input without one (held as drawn)."""
    robot = scene.model.robot if isinstance(scene.model, RobotModelSpec) else None
    assert robot is not None
    names = list(robot.cables.names)
    out: dict[str, float] = {}
    for name, law in scene.inputs.items():
        if isinstance(law, Commanded):
            if law.initial is not None:
                out[name] = float(law.initial)
            continue
        a, b = robot.cables.ends[names.index(name)]
        out[name] = float(law.value_at(0.0, float(np.linalg.norm(robot.nodes[b] - robot.nodes[a]))))
    return out


def scene_floor(scene: Scene) -> Floor | None:
    """The floor a robot scene simulates: its robot's floor with the scene's ``contact``
    (stiffness, dissipation) and ``friction`` (coefficients and lever arms, the anchor's
    stiffness and damping; frictionless without it), or None without ``contact``."""
    model = scene.model
    assert isinstance(model, RobotModelSpec)
    floor = model.robot.floor
    contact, friction = scene.effects.get("contact"), scene.effects.get("friction")
    if floor is None or not isinstance(contact, ContactSpec):
        return None
    if not isinstance(friction, FrictionSpec):
        friction = FrictionSpec(0.0, 0.0, floor.tangential_stiffness, floor.tangential_damping)
    return dataclasses.replace(floor, stiffness=contact.stiffness, dissipation=contact.dissipation,
                               mu_static=friction.mu_static, mu_kinetic=friction.mu_kinetic,
                               tangential_stiffness=friction.tangential_stiffness,
                               tangential_damping=friction.tangential_damping,
                               rolling_friction=friction.rolling_friction,
                               torsional_friction=friction.torsional_friction)


def rod_inertial(robot: Robot, i: int) -> tuple[float, float, float, float]:
    """``(mass [kg], centre of mass [m] along the rod's axis from its centre, I_t, I_a [kg m^2]
    about that centre of mass)`` of rod ``i`` with the point masses riding on its caps (at
    ``-L/2`` and ``+L/2`` along its axis: ``I_a`` unchanged, ``I_t`` by the parallel axis);
    raises :class:`ExportError` where MuJoCo cannot take it (:data:`~.mujoco_limits.MJMINVAL`)."""
    rods = robot.rods
    a, b = (int(n) for n in rods.ends[i])
    half = 0.5 * float(np.linalg.norm(robot.nodes[b] - robot.nodes[a]))
    m_a, m_b = float(robot.node_masses[a]), float(robot.node_masses[b])
    mass = float(rods.mass[i]) + m_a + m_b
    com = half * (m_b - m_a) / mass
    I_t, I_a = (float(x) for x in rods.inertia[i])
    I_t += (m_a + m_b) * half ** 2 - mass * com ** 2
    least = min(I_t, I_a)
    if not least >= MJMINVAL * (1.0 + MJMINVAL_MARGIN):
        which = "transverse" if I_t <= I_a else "axial"
        raise ExportError(f"robot {robot.name!r}: rods[{i}].inertia: rod {rods.names[i]!r} has {which} inertia "
                          f"{least:.3g} kg m^2 (with its caps' point masses); {MJMINVAL_WHY}")
    return mass, com, I_t, I_a


def contact_parameters(stiffness: float, body_mass: float, impedance: float = CONTACT_IMPEDANCE
                       ) -> tuple[float, float]:
    """MuJoCo's direct ``solref = (-S, -D)`` [1/s^2, 1/s] for a cap of a body of ``body_mass``
    [kg] on a floor of Hunt-Crossley ``stiffness`` [N/m], with the constant ``impedance`` d:
    ``S = (1 - d) k / m`` (the same rest penetration) and ``D = 2 sqrt(S)`` (critical damping:
    no bounce); module docstring."""
    S = (1.0 - impedance) * stiffness / body_mass
    return S, 2.0 * math.sqrt(S)


class _RobotWriter:
    """One export: the robot's parts, written element by element."""

    def __init__(self, robot: Robot, timestep: float, integrator: str, lift: float, name: str,
                 commands: dict[str, float]):
        self.robot = robot
        self.commands = commands
        self.name = name
        self.lift = lift * (robot.floor.normal if robot.floor is not None else np.array([0.0, 0.0, 1.0]))
        self.timestep = float(timestep)
        self.integrator = integrator
        lay = bodies_layout(robot)
        self.lay = lay
        rod_nodes = robot.rods.ends.ravel()
        if np.any(lay.fixed_mask[rod_nodes]):
            i = int(rod_nodes[np.flatnonzero(lay.fixed_mask[rod_nodes].any(axis=1))[0]])
            raise ExportError(f"robot {robot.name!r}: rod end {robot.node_names[i]!r} is pinned; MJCF rods are "
                              f"free bodies (pin a rigid body instead)")
        self.rods = [rod_inertial(robot, i) for i in range(len(robot.rods))]
        # a body's mass shared equally by its nodes, plus their point masses (the general dynamics' lumping)
        masses = robot.node_masses.copy()
        for body in robot.bodies:
            masses[list(body.nodes)] += body.mass / len(body.nodes)
        self.bodies = layout_inertias(lay, masses)
        for slot, b in enumerate(self.bodies):
            I = b.inertia + INERTIA_MARGIN * float(np.trace(b.inertia)) * np.eye(3)
            least = float(np.linalg.eigvalsh(I).min())
            if not least >= MJEPS * (1.0 + MJMINVAL_MARGIN):
                j = [b_.name for b_ in robot.bodies].index(lay.body_names[slot])
                raise ExportError(f"robot {robot.name!r}: rigid_bodies[{j}]: body {lay.body_names[slot]!r} has a "
                                  f"principal inertia of {least:.3g} kg m^2 (of its nodes' masses); MuJoCo refuses "
                                  f"a full inertia tensor with an eigenvalue below its mjEPS, {MJEPS:g} kg m^2: give "
                                  f"the body more mass or size")
        self.qpos: list[float] = []
        self.ctrl: list[float] = []
        self.act: list[float] = []
        self.sensors = 0
        self.contacts = 0

    # -- the document ----------------------------------------------------------------------------
    def model(self) -> MjcfModel:
        r = self.robot
        root = ET.Element("mujoco", model=self.name)
        root.append(ET.Comment(
            f" tensegrity export mjcf: {self.name}, robot {r.name} ({r.description or 'no description'}). What MuJoCo does "
            f"differently: docs/mujoco.md. Motors: {CTRL_MEANING}; tension = -actuator force [N]. "))
        ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false", alignfree="false",
                      autolimits="true")
        option = ET.SubElement(root, "option", timestep=number(self.timestep), integrator=self.integrator,
                               gravity=vector(r.gravity), cone="elliptic", impratio=number(FRICTION_IMPRATIO))
        if r.floor is None:
            ET.SubElement(option, "flag", contact="disable")
        self._defaults(root)
        world = ET.SubElement(root, "worldbody")
        self._floor(world)
        self._world_sites(world)
        for i in range(len(r.rods)):
            self._rod(world, i)
        for slot in range(len(self.lay.moving_bodies)):
            self._rigid_body(world, slot)
        point_masses = self._point_masses(world)
        self._contacts(root)
        self._tendons(root)
        self._actuators(root)
        self._sensors(root)
        key = ET.SubElement(ET.SubElement(root, "keyframe"), "key", name="initial", qpos=vector(self.qpos),
                            qvel=vector(np.zeros(self._nv())))
        if self.ctrl:
            key.set("ctrl", vector(self.ctrl))
        if self.act:
            key.set("act", vector(self.act))
        ET.indent(root, space="  ")
        xml = ET.tostring(root, encoding="unicode") + "\n"
        return MjcfModel(name=self.name, xml=xml, timestep=self.timestep, integrator=self.integrator,
                         fastest_rate=math.nan, node_bodies=point_masses,
                         rigid_bodies=len(r.rods) + len(self.lay.moving_bodies), tendons=len(r.cables), loads=0,
                         actuator_members=0, nq=len(self.qpos), nv=self._nv(), rods=len(r.rods),
                         motors=len(r.motors), contacts=self.contacts, sensors=self.sensors)

    def _nv(self) -> int:
        return len(self.qpos) - len(self.robot.rods) - len(self.lay.moving_bodies)     # a quaternion each

    def _defaults(self, root: ET.Element) -> None:
        """Colours and widths for the viewer: rods grey, caps dark, passive cables orange, actuated green."""
        extent = float(np.ptp(self.robot.nodes, axis=0).max()) or 1.0
        default = ET.SubElement(root, "default")
        ET.SubElement(default, "site", size=number(0.01 * extent), rgba="0.2 0.2 0.2 1")
        ET.SubElement(default, "geom", contype="0", conaffinity="0")
        for kind, rgba in (("passive", "0.85 0.3 0.1 1"), ("actuated", "0.2 0.6 0.3 1")):
            ET.SubElement(ET.SubElement(default, "default", {"class": kind}), "tendon",
                          width=number(0.004 * extent), rgba=rgba)

    def _floor(self, world: ET.Element) -> None:
        floor = self.robot.floor
        if floor is not None:
            ET.SubElement(world, "geom", name="floor", type="plane", size="0 0 1", pos=vector(floor.point),
                          zaxis=vector(floor.normal), rgba="0.8 0.8 0.75 1")

    def _world_sites(self, world: ET.Element) -> None:
        """Pinned nodes and the nodes of fixed bodies: world sites."""
        lay = self.lay
        for i in np.flatnonzero(lay.fixed_mask.all(axis=1) & (lay.node_body < 0)):
            ET.SubElement(world, "site", name=self._node(int(i)), pos=vector(self.robot.nodes[i]))
        r = self.robot
        for k in r.sensors.imu_bodies:
            if r.bodies[k].fixed:
                ET.SubElement(world, "site", name=f"imu:{r.bodies[k].name}",
                              pos=vector(r.nodes[list(r.bodies[k].nodes)].mean(axis=0)))

    def _rod(self, world: ET.Element, i: int) -> None:
        r = self.robot
        rods = r.rods
        a, b = (int(n) for n in rods.ends[i])
        xa, xb = r.nodes[a], r.nodes[b]
        half = 0.5 * float(np.linalg.norm(xb - xa))
        frame = rod_frames(xa, xb)[0]
        mass, com, I_t, I_a = self.rods[i]
        name = f"rod:{rods.names[i]}"
        shift = frame_shift(np.array([0.0, 0.0, com]), np.array([[0.0, 0.0, -half], [0.0, 0.0, half]]),
                            f"robot {r.name!r}: rods[{i}]: rod {rods.names[i]!r}",
                            float(np.abs([xa, xb]).max()))[2]
        origin = 0.5 * (xa + xb) + shift * frame[:, 2] + self.lift
        quat = Rotation.from_matrix(frame).as_quat(scalar_first=True)
        body = ET.SubElement(world, "body", name=name, pos=vector(origin), quat=vector(quat))
        ET.SubElement(body, "freejoint", name=name)
        self.qpos.extend([*origin, *quat])
        ET.SubElement(body, "inertial", pos=vector([0.0, 0.0, com - shift]), mass=number(mass),
                      diaginertia=vector([I_t, I_t, I_a]))
        if rods.radius[i] > 0:                        # a slender rod (radius 0) is drawn by its caps alone
            ET.SubElement(body, "geom", name=name, type="capsule", size=number(rods.radius[i]),
                          fromto=vector([0, 0, -half - shift, 0, 0, half - shift]), rgba="0.55 0.55 0.6 1")
        for node, z in ((a, -half - shift), (b, half - shift)):
            ET.SubElement(body, "geom", name=f"cap:{r.node_names[node]}", type="sphere",
                          size=number(rods.cap_radius[i]), pos=vector([0, 0, z]), rgba="0.25 0.25 0.3 1")
            ET.SubElement(body, "site", name=self._node(node), pos=vector([0, 0, z]))
        if i in r.sensors.imu_rods:
            # the project's rod frame has the world's axes in the drawing (its IMU reads in it):
            # the site undoes the body's turn onto the rod's principal axes
            drawn_axes = Rotation.from_matrix(frame).inv().as_quat(scalar_first=True)
            ET.SubElement(body, "site", name=f"imu:{rods.names[i]}", pos=vector([0.0, 0.0, -shift]),
                          quat=vector(drawn_axes))

    def _rigid_body(self, world: ET.Element, slot: int) -> None:
        lay = self.lay
        body_name = lay.body_names[slot]
        name = f"body:{body_name}"
        b = self.bodies[slot]
        index = [b_.name for b_ in self.robot.bodies].index(body_name)
        nodes = lay.body_nodes[slot]
        shift = frame_shift(b.com, lay.offsets[nodes], f"robot {self.robot.name!r}: rigid_bodies[{index}]: body "
                                                       f"{body_name!r}", float(np.abs(self.robot.nodes[nodes]).max()))
        origin = self.robot.nodes[list(nodes)].mean(axis=0) + shift + self.lift
        body = ET.SubElement(world, "body", name=name, pos=vector(origin))
        ET.SubElement(body, "freejoint", name=name)
        self.qpos.extend([*origin, 1.0, 0.0, 0.0, 0.0])
        I = b.inertia + INERTIA_MARGIN * float(np.trace(b.inertia)) * np.eye(3)
        ET.SubElement(body, "inertial", pos=vector(b.com - shift), mass=number(b.mass),
                      fullinertia=vector([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
        for i in nodes:
            ET.SubElement(body, "site", name=self._node(int(i)), pos=vector(lay.offsets[i] - shift))
        if index in self.robot.sensors.imu_bodies:
            ET.SubElement(body, "site", name=f"imu:{body_name}", pos=vector(-shift))

    def _point_masses(self, world: ET.Element) -> int:
        """Free nodes that are neither rod ends nor in a body: point masses on slide joints."""
        r, lay = self.robot, self.lay
        loose = ~lay.fixed_mask.all(axis=1) & (lay.node_body < 0)
        loose[r.rods.ends.ravel()] = False
        for i in np.flatnonzero(loose):
            m = float(r.node_masses[i])
            if m <= 0:
                raise ExportError(f"robot {r.name!r}: free node {r.node_names[i]!r} has no mass; give it a point "
                                  f"mass or make it a rod end")
            body = ET.SubElement(world, "body", name=self._node(int(i)), pos=vector(r.nodes[i] + self.lift))
            for axis in range(3):
                if not lay.fixed_mask[i, axis]:
                    ET.SubElement(body, "joint", name=f"{self._node(int(i))}:{'xyz'[axis]}", type="slide",
                                  axis=vector(np.eye(3)[axis]))
                    self.qpos.append(0.0)
            ET.SubElement(body, "inertial", pos="0 0 0", mass=number(m), diaginertia=vector([m, m, m]))
            ET.SubElement(body, "site", name=self._node(int(i)))
        return int(loose.sum())

    def _contacts(self, root: ET.Element) -> None:
        """One contact pair per end cap with the floor (module docstring)."""
        r, floor = self.robot, self.robot.floor
        if floor is None or not len(r.rods):
            return
        contact = ET.SubElement(root, "contact")
        d = CONTACT_IMPEDANCE
        turning = floor.rolling_friction > 0.0 or floor.torsional_friction > 0.0
        mu = [floor.mu_static, floor.mu_static, floor.torsional_friction, floor.rolling_friction,
              floor.rolling_friction]
        for i in range(len(r.rods)):
            S, D = contact_parameters(floor.stiffness, self.rods[i][0])
            for node in r.rods.ends[i]:
                name = r.node_names[int(node)]
                ET.SubElement(contact, "pair", name=f"contact:{name}", geom1=f"cap:{name}", geom2="floor",
                              condim="6" if turning else "3", friction=vector(mu),
                              solref=vector([-S, -D]), solimp=vector([d, d, 0.001, 0.5, 2]))
                self.contacts += 1

    def _tendons(self, root: ET.Element) -> None:
        r = self.robot
        c = r.cables
        tendons = ET.SubElement(root, "tendon")
        for i in range(len(c)):
            attrs = {"name": f"cable:{c.names[i]}"}
            if c.motor[i] >= 0:
                attrs["class"] = "actuated"
            else:
                attrs.update({"class": "passive", "stiffness": number(c.stiffness[i]),
                              "springlength": vector([0.0, c.rest_length[i]])})
                if c.damping[i] > 0:
                    attrs["damping"] = number(c.damping[i])
            tendon = ET.SubElement(tendons, "spatial", attrs)
            for node in c.ends[i]:
                ET.SubElement(tendon, "site", site=self._node(int(node)))

    def _actuators(self, root: ET.Element) -> None:
        if not len(self.robot.motors):
            return
        motors = motor_actuators(self.robot)
        ET.SubElement(root, "actuator").extend(motors.elements)
        self.ctrl, self.act = motors.ctrl, motors.act
        cables = self.robot.cables.names
        for j, cable in enumerate(self.robot.motors.cable):
            self.ctrl[j] = self.commands.get(cables[int(cable)], self.ctrl[j])

    def _sensors(self, root: ET.Element) -> None:
        r = self.robot
        c, s = r.cables, r.sensors
        sensor = ET.Element("sensor")
        for i in s.cable_length:
            ET.SubElement(sensor, "tendonpos", name=f"length:{c.names[i]}", tendon=f"cable:{c.names[i]}")
        for i in s.cable_tension:
            if c.motor[i] >= 0:
                ET.SubElement(sensor, "actuatorfrc", name=f"tension:{c.names[i]}", actuator=f"cable:{c.names[i]}")
        imus = [r.rods.names[i] for i in s.imu_rods] + [r.bodies[i].name for i in s.imu_bodies]
        for name in imus:
            site = f"imu:{name}"
            ET.SubElement(sensor, "framequat", name=f"{site}:orientation", objtype="site", objname=site)
            ET.SubElement(sensor, "gyro", name=f"{site}:gyro", site=site)
            ET.SubElement(sensor, "accelerometer", name=f"{site}:accelerometer", site=site)
        self.sensors = len(sensor)
        if len(sensor):
            root.append(sensor)

    def _node(self, i: int) -> str:
        return f"node:{self.robot.node_names[i]}"
