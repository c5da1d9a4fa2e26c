"""A robot compiled into the constant arrays its dynamics' kernels read.

A :class:`RobotPlan` is the robot's topology and constants (MuJoCo's ``mjModel``), built
once per scene from the :class:`~tensegrity_core.robot.description.Robot` and the scene's
effects (:class:`RobotEffects`: which are listed, with their overrides):

- **bodies**: every rod is a rigid body of its two end caps (its own mass and capsule
  inertia, :mod:`tensegrity_core.robot.rod`), every other rigid body of the description a
  body of its nodes (its mass shared equally by them, as in the general dynamics); point
  masses ride on the body of their node or make a free node. The placement and
  Newton-Euler arrays are those of the general kernels' :class:`~tensegrity_core.sim.general.kernels.plan.Plan`
  (``base`` .. ``body_inv_inertia_cm``), so :mod:`.loops` calls the general ``place`` and
  ``rates`` on them; ``external`` (n, 3) [N] holds the weights (a rod's at its caps, half each:
  exact for force and moment, its centre of mass being the midpoint);
- **cables** (c): ends, stiffness ``k`` [N/m], damping ``c`` [N s/m], tension limit [N] (inf:
  none), drawn rest length [m] and motor slot (-1: passive);
- **motors** (a, in input order): cable, rest-length range [m], lag [s] (0: none) and slew
  limit [m/s] (inf: none); without the ``motors`` effect every motor is ideal (the rest
  length follows its input at once) and holds any tension;
- **caps** (the rods' end caps, only with ``contact``): node, body slot, radius [m];
- **floor**: unit normal, a point, and ``floor_params`` = (k [N/m], d [s/m], mu_s, mu_k,
  k_t [N/m], c_t [N s/m], rolling and torsional friction [m]); without ``friction``
  ``k_t = c_t = 0``, no anchor is made and the caps roll and spin freely.

Body frames are the drawing's axes (the rotation charts start at the identity), inertia
about each body's reference point ``c`` (the centroid of its nodes: a rod's midpoint).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.layout import robot_layout
from tensegrity_core.robot.rod import rod_frames, world_inertia
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.general.kernels.plan import build_placement, frozen

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class RobotEffects:
    """The robot effects a scene lists, with the values they override (None: the
    description's). ``gravity`` (3,) [m/s^2] or None; ``motors``, ``contact``, ``friction``
    listed or not; overrides: every motor's ``tau`` [s], ``max_speed`` [m/s],
    ``max_tension`` [N]; the floor's ``stiffness`` [N/m], ``dissipation`` [s/m],
    ``mu_static``, ``mu_kinetic``, ``tangential_stiffness`` [N/m], ``tangential_damping``
    [N s/m], ``rolling_friction`` and ``torsional_friction`` [m]."""

    gravity: tuple[float, float, float] | None = None
    motors: bool = False
    contact: bool = False
    friction: bool = False
    tau: float | None = None
    max_speed: float | None = None
    max_tension: float | None = None
    stiffness: float | None = None
    dissipation: float | None = None
    mu_static: float | None = None
    mu_kinetic: float | None = None
    tangential_stiffness: float | None = None
    tangential_damping: float | None = None
    rolling_friction: float | None = None
    torsional_friction: float | None = None


class RobotPlan(NamedTuple):
    """A robot's constant arrays (module docstring); the first twelve are the general
    kernels' :class:`~tensegrity_core.sim.general.kernels.plan.Placement` (built by its
    ``build_placement``), then the weights ``external``."""

    base: FloatArray
    free_node: IntArray
    free_axis: IntArray
    free_inv_mass: FloatArray
    on_node: IntArray
    on_body: IntArray
    on_offset: FloatArray
    body_dof: IntArray
    body_mass: FloatArray
    body_first_moment: FloatArray
    body_inertia: FloatArray
    body_inv_inertia_cm: FloatArray
    external: FloatArray
    cable_a: IntArray
    cable_b: IntArray
    cable_k: FloatArray
    cable_c: FloatArray
    cable_t_max: FloatArray
    cable_l0: FloatArray
    cable_motor: IntArray
    motor_cable: IntArray
    motor_lo: FloatArray
    motor_hi: FloatArray
    motor_tau: FloatArray
    motor_speed: FloatArray
    cap_node: IntArray
    cap_body: IntArray
    cap_radius: FloatArray
    floor_normal: FloatArray
    floor_point: FloatArray
    floor_params: FloatArray

    @property
    def n_dof(self) -> int:
        """Length of the coordinates ``x`` (and of the rates ``v``)."""
        return len(self.free_node) + 6 * len(self.body_dof)

    @property
    def n_state(self) -> int:
        """Length of the state vector: ``x``, ``v``, the motors' rest lengths, per cap its
        anchor (3) and its contact state (1)."""
        return 2 * self.n_dof + len(self.motor_cable) + 4 * len(self.cap_node)


def build_plan(robot: Robot, effects: RobotEffects) -> RobotPlan:
    """The plan of ``robot`` under the scene's ``effects`` (see the module docstring)."""
    lay = robot_layout(robot)
    nb = len(lay.moving_bodies)
    nr = len(robot.rods)
    # -- masses: rods (capsule inertia), other bodies (mass shared by their nodes), point masses
    mass = np.zeros(nb)
    first = np.zeros((nb, 3))
    inertia = np.zeros((nb, 3, 3))
    weight_mass = robot.lumped_masses()
    ends = robot.rods.ends
    frames = rod_frames(robot.nodes[ends[:, 0]], robot.nodes[ends[:, 1]])
    rod_I = world_inertia(frames, robot.rods.inertia[:, 0], robot.rods.inertia[:, 1])
    slot_of = {k: s for s, k in enumerate(lay.moving_bodies)}
    for k in range(nr):
        s = slot_of[k]
        mass[s] = robot.rods.mass[k]
        inertia[s] = rod_I[k]
    for j, body in enumerate(robot.bodies):
        share = body.mass / len(body.nodes)
        if j + nr in slot_of:
            s = slot_of[j + nr]
            for node in body.nodes:
                _add_point(mass, first, inertia, s, share, lay.offsets[node])
    on = np.flatnonzero(lay.node_body >= 0)
    for carried in on.tolist():
        if robot.node_masses[carried] > 0:
            _add_point(mass, first, inertia, int(lay.node_body[carried]), float(robot.node_masses[carried]),
                       lay.offsets[carried])
    light = [lay.body_names[s] for s in range(nb) if not mass[s] > 0]
    if light:
        raise SceneError(f"inertia needs mass on every moving body; {', '.join(map(repr, light))} "
                         f"{'has' if len(light) == 1 else 'have'} none",
                         key=("model", "robot"))
    free = np.nonzero(lay.free_index >= 0)
    free_node = free[0][np.argsort(lay.free_index[free])]          # per free coordinate, in the layout's order
    free_mass = np.asarray(robot.node_masses, dtype=float)[free_node]
    if np.any(free_mass <= 0):
        bad = robot.node_names[int(free_node[np.argmax(free_mass <= 0)])]
        raise SceneError(f"inertia needs a mass on every free node; {bad!r} has none (give it a point mass or put "
                         f"it on a rod or body)", key=("model", "robot"))
    placement = build_placement(lay, robot.nodes, free_masses=free_mass, body_masses=mass, body_first_moments=first,
                                body_inertia=inertia)
    g = np.zeros(3) if effects.gravity is None else np.asarray(effects.gravity, dtype=float)
    # -- cables and motors
    cab, mot = robot.cables, robot.motors
    actuated = cab.actuated
    motor_slot = np.full(len(cab), -1, dtype=np.int64)
    motor_slot[actuated] = np.arange(len(actuated))
    t_max = np.full(len(cab), math.inf)
    by_cable = {int(c): i for i, c in enumerate(mot.cable)}         # motor index of each actuated cable
    order_m = np.array([by_cable[int(c)] for c in actuated], dtype=np.int64)
    lo, hi = mot.range[order_m, 0].copy(), mot.range[order_m, 1].copy()
    if effects.motors:
        tau = np.full(len(actuated), effects.tau) if effects.tau is not None else mot.tau[order_m].copy()
        speed = np.full(len(actuated), effects.max_speed) if effects.max_speed is not None \
            else mot.max_speed[order_m].copy()
        t_max[actuated] = effects.max_tension if effects.max_tension is not None else mot.max_tension[order_m]
    else:
        tau, speed = np.zeros(len(actuated)), np.full(len(actuated), math.inf)
    # -- caps and floor
    floor = robot.floor
    if effects.contact:
        if floor is None:
            raise SceneError(f"effect 'contact' needs a floor, and robot {robot.name!r} has none (give it a 'floor')",
                             key=("effects",))
        cap_node = ends.reshape(-1).astype(np.int64)
        cap_radius = np.repeat(robot.rods.cap_radius, 2)
        cap_body = lay.node_body[cap_node].astype(np.int64)

        def pick(override: float | None, value: float) -> float:
            return float(value if override is None else override)
        params = np.array([pick(effects.stiffness, floor.stiffness), pick(effects.dissipation, floor.dissipation),
                           pick(effects.mu_static, floor.mu_static), pick(effects.mu_kinetic, floor.mu_kinetic),
                           pick(effects.tangential_stiffness, floor.tangential_stiffness) if effects.friction else 0.0,
                           pick(effects.tangential_damping, floor.tangential_damping) if effects.friction else 0.0,
                           pick(effects.rolling_friction, floor.rolling_friction) if effects.friction else 0.0,
                           pick(effects.torsional_friction, floor.torsional_friction) if effects.friction else 0.0])
        normal, point = np.array(floor.normal, dtype=float), np.array(floor.point, dtype=float)
    else:
        cap_node, cap_body, cap_radius = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
        params, normal, point = np.zeros(8), np.array([0.0, 0.0, 1.0]), np.zeros(3)
    return frozen(RobotPlan(
        *placement,
        external=weight_mass[:, None] * g[None, :],
        cable_a=np.array(cab.ends[:, 0], dtype=np.int64), cable_b=np.array(cab.ends[:, 1], dtype=np.int64),
        cable_k=np.array(cab.stiffness, dtype=float), cable_c=np.array(cab.damping, dtype=float), cable_t_max=t_max,
        cable_l0=np.array(cab.rest_length, dtype=float), cable_motor=motor_slot,
        motor_cable=np.asarray(actuated, dtype=np.int64), motor_lo=lo, motor_hi=hi, motor_tau=tau,
        motor_speed=speed, cap_node=cap_node, cap_body=cap_body, cap_radius=np.array(cap_radius, dtype=float),
        floor_normal=normal, floor_point=point, floor_params=params))


def _add_point(mass: FloatArray, first: FloatArray, inertia: FloatArray, slot: int, m: float, p: FloatArray) -> None:
    """Add a point mass ``m`` [kg] at body-frame offset ``p`` [m] to body ``slot``."""
    mass[slot] += m
    first[slot] += m * p
    inertia[slot] += m * (float(p @ p) * np.eye(3) - np.outer(p, p))
