"""Which modelling differences part the project's and MuJoCo's rolling 6-bar, and which
layouts of the derived rolling gait make its faces independent of the simulator
(docs/design/mujoco.md, "The project's robot dynamics against MuJoCo", "A decisive roll").

Run from the repository root with the ``mujoco`` extra installed (``./run setup``)::

    .venv/bin/python docs/robot_mujoco_order.py                  # every experiment, one line each
    .venv/bin/python docs/robot_mujoco_order.py "MuJoCo, RK4 (as exported)"     # one of EXPERIMENTS
    .venv/bin/python docs/robot_mujoco_order.py "tip budget"     # what a tip's time is made of

The two models are made equal one difference at a time. MuJoCo runs a scene's export
(``export_mjcf(load_scene(...))``, its integrator and step overridden) driven either by the
gait ``six_bar_roll`` as :func:`tests.mujoco_peer.play_gait` drives it (its tipping moves
laid out again by :func:`laid_out` where an experiment names a ``layout``), or by the closed-loop
controller (:class:`tensegrity_core.robot.roll_control.RollController`, 50 Hz) from
``six_bar_rest``; with its own contacts, or with its contacts switched off and **the
project's floor law** applied as passive forces (``mujoco.set_mjcb_passive``, so every
stage of MuJoCo's RK4 feels it): the Hunt-Crossley normal force, the friction anchors
(:mod:`tensegrity_core.robot.friction`: the offset moves with the contact's material point,
return-mapped once per step) and the rolling and spin couples
(:mod:`tensegrity_core.robot.contact`), each computed by the project's own functions from
MuJoCo's state. Parts of that law can be swapped for MuJoCo-like ones (:class:`FloorLaw`), and the
motors' commands limited as the project's slew limit limits them (:func:`slew_limited`).
Faces are counted as :func:`tests.mujoco_peer.play_gait` counts them (exactly three caps each
carrying more than 2 % of the weight, at every step), from the law's normal forces when it
replaces MuJoCo's contacts. A run of 13 s with the project's law takes ~10 CPU seconds.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tensegrity_core.export import export_mjcf  # noqa: E402
from tensegrity_core.export.robot_mjcf import scene_floor  # noqa: E402
from tensegrity_core.robot.contact import normal_force, resisting_couple  # noqa: E402
from tensegrity_core.robot.friction import stage_force, tangential  # noqa: E402
from tensegrity_core.robot.gait import GAITS_DIR, Gait, gait_from_file, gait_to_dict  # noqa: E402
from tensegrity_core.robot.roll_control import RollController  # noqa: E402
from tensegrity_core.robot.tipping import hull_faces, place_on_face, tipping_steps  # noqa: E402
from tensegrity_core.sim import Scene, compile_scene, load_scene, simulate  # noqa: E402
from tensegrity_core.sim.control_loop import ControlLoop  # noqa: E402
from tensegrity_core.sim.scene import SCENES_DIR  # noqa: E402
from tests.mujoco_peer import CAP, touching_caps  # noqa: E402

FloatArray = NDArray[np.float64]
#: The faces reported are those reached from this time [s] on (where the orders part).
FROM = 4.0
#: The release-free layout's cycle [s] (13 s): :func:`laid_out` with ``rest=None``.
DURATION = 13.0
#: A layout of the derived moves, :func:`laid_out`'s arguments: ``(hold, rest[, overlap[, spread]])``.
Layout = tuple[float, float | None] | tuple[float, float | None, bool] | tuple[float, float | None, bool, float]
#: ``(hold, rest)`` [s] of the release-free layout (the next move and the release together).
RELEASE_FREE = (0.6, None)
#: The closed-loop controller's period [s] (50 Hz).
PERIOD = 0.02
#: A cap touches when it carries more than this share of the weight (as play_gait counts).
SHARE = 0.02


@dataclass(frozen=True)
class FloorLaw:
    """Which floor law :class:`ProjectFloor` applies: the normal force (``"hunt-crossley"``:
    the project's; ``"linear"``: ``k delta + 2 sqrt(k m) deltadot``, critically damped as
    MuJoCo's ``solref``), the tangential friction (``"anchor"``: the project's stick-slip
    anchors; ``"regularised"``: ``mu_k F_n`` against the contact point's slip velocity,
    linear below ``slip_speed`` [m/s], a creep like MuJoCo's; ``"none"``) and whether the
    rolling and spin couples act."""

    normal: str = "hunt-crossley"
    friction: str = "anchor"
    couples: bool = True
    slip_speed: float = 1e-3


class ProjectFloor:
    """The project's floor law (:mod:`tensegrity_core.robot.contact`,
    :mod:`tensegrity_core.robot.friction`, computed by their functions) acting on an exported
    robot in MuJoCo in place of MuJoCo's contacts: :meth:`attach` switches MuJoCo's contacts
    off and installs :meth:`passive` as MuJoCo's passive-force callback, so every stage of
    its integrator feels the law at that stage's state; call :meth:`step_end` after every
    ``mj_step`` (the anchors' return map once per step, as the project's sampled update) and
    :meth:`detach` at the end. The anchors' offsets move with the contact's material point
    (fixed in the body at the step's start). ``floor``: the scene's robot's
    :class:`~tensegrity_core.robot.description.Floor` with the scene's contact and friction
    (``write_robot_scene`` applies the same)."""

    def __init__(self, floor, node_names: Sequence[str], law: FloorLaw = FloorLaw()):
        self.law = law
        self.n = np.asarray(floor.normal, dtype=float)
        self.point = np.asarray(floor.point, dtype=float)
        self.floor = floor
        self.names = tuple(node_names)

    def attach(self, m: mujoco.MjModel, d: mujoco.MjData) -> FloatArray:
        """Use the law in ``m`` from the state ``d``; returns the caps' normal forces [N] there."""
        geoms = [m.geom(f"{CAP}{n}").id for n in self.names]
        body = np.array([m.geom_bodyid[g] for g in geoms])
        self.bodies, self.slot = np.unique(body, return_inverse=True)
        joints = m.body_jntadr[self.bodies]
        self.qadr, self.vadr = m.jnt_qposadr[joints], m.jnt_dofadr[joints]
        self.local = np.array([m.geom_pos[g] for g in geoms])
        self.radius = np.array([m.geom_size[g][0] for g in geoms])
        self.mass = m.body_subtreemass[body]
        ncap = len(geoms)
        self.s = np.zeros((ncap, 3))
        self.anchored = np.zeros(ncap, dtype=bool)
        self.slipping = np.zeros(ncap, dtype=bool)
        self.material = np.zeros((ncap, 3))
        self.start = np.zeros((ncap, 3))
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        mujoco.set_mjcb_passive(self.passive)
        mujoco.mj_forward(m, d)
        return self.step_end(d)

    @staticmethod
    def detach() -> None:
        mujoco.set_mjcb_passive(None)

    def _kinematics(self, d: mujoco.MjData) -> tuple[FloatArray, ...]:
        """Per body its rotation and centre, per cap its rotation, centre, velocity and the
        body's angular velocity (world), from the free joints' ``qpos``, ``qvel``."""
        q = d.qpos[self.qadr[:, None] + np.arange(7)]
        qv = d.qvel[self.vadr[:, None] + np.arange(6)]
        R_b = Rotation.from_quat(q[:, 3:], scalar_first=True).as_matrix()
        R, com = R_b[self.slot], q[self.slot, :3]
        arm = np.einsum("cij,cj->ci", R, self.local)
        w = np.einsum("cij,cj->ci", R, qv[self.slot, 3:])
        return R_b, R, com, com + arm, qv[self.slot, :3] + np.cross(w, arm), w

    def _normal(self, x: FloatArray, v: FloatArray) -> FloatArray:
        f = self.floor
        delta = self.radius - (x - self.point) @ self.n
        rate = -(v @ self.n)
        if self.law.normal == "hunt-crossley":
            return normal_force(delta, rate, f.stiffness, f.dissipation)
        out: FloatArray = np.where(delta > 0, np.maximum(f.stiffness * delta + 2 * np.sqrt(f.stiffness * self.mass)
                                                         * rate, 0.0), 0.0)
        return out

    def passive(self, m: mujoco.MjModel, d: mujoco.MjData) -> None:
        """MuJoCo's passive-force callback: the law's forces at the current (stage) state."""
        f = self.floor
        R_b, R, com, x, v, w = self._kinematics(d)
        F_n = self._normal(x, v)
        point = x - self.radius[:, None] * self.n
        v_t = tangential(v + np.cross(w, point - x), self.n)
        ones = np.ones(len(F_n))
        if self.law.friction == "anchor":
            trial = tangential(self.s + com + np.einsum("cij,cj->ci", R, self.material) - self.start, self.n)
            F_t = np.where(self.anchored[:, None], stage_force(trial, v_t, F_n, f.tangential_stiffness * ones,
                                                               f.tangential_damping * ones, f.mu_static * ones,
                                                               f.mu_kinetic * ones, self.slipping), 0.0)
        elif self.law.friction == "regularised":
            speed = np.sqrt(np.sum(v_t * v_t, axis=1))
            F_t = -(f.mu_kinetic * F_n / np.maximum(speed, self.law.slip_speed))[:, None] * v_t
        else:
            F_t = np.zeros_like(v_t)
        torque = np.cross(x - com, F_n[:, None] * self.n) + np.cross(point - com, F_t)
        if self.law.couples:
            torque += resisting_couple(w, F_n, self.n, f.rolling_friction, f.torsional_friction)
        force = np.zeros((len(self.bodies), 3))
        moment = np.zeros((len(self.bodies), 3))
        np.add.at(force, self.slot, F_n[:, None] * self.n + F_t)
        np.add.at(moment, self.slot, torque)
        # a free joint's rotational dofs are in the body's frame
        d.qfrc_passive[self.vadr[:, None] + np.arange(3)] += force
        d.qfrc_passive[self.vadr[:, None] + 3 + np.arange(3)] += np.einsum("bji,bj->bi", R_b, moment)

    def step_end(self, d: mujoco.MjData) -> FloatArray:
        """The anchors' return map at the end of a step (``tensegrity_core.sim.general.robot.
        loops.sampled_update``'s rule); returns the caps' normal forces [N] at the new state."""
        f = self.floor
        _, R, com, x, v, _ = self._kinematics(d)
        F_n = self._normal(x, v)
        trial = tangential(self.s + com + np.einsum("cij,cj->ci", R, self.material) - self.start, self.n)
        size = np.sqrt(np.sum(trial * trial, axis=1))
        hold = np.where(self.slipping, f.mu_kinetic, f.mu_static) * F_n
        touching = (F_n > 0) & (f.tangential_stiffness > 0)
        sticks = f.tangential_stiffness * size <= hold
        scale = np.divide(f.mu_kinetic * F_n, f.tangential_stiffness * size, out=np.zeros_like(size), where=size > 0)
        kept = touching & self.anchored
        self.s = np.where((kept & sticks)[:, None], trial, np.where(kept[:, None], scale[:, None] * trial, 0.0))
        self.slipping = kept & ~sticks
        self.anchored = touching
        point = x - self.radius[:, None] * self.n
        self.start = point
        self.material = np.einsum("cji,cj->ci", R, point - com)
        return F_n


def slew_limited(command: ArrayLike, l0: ArrayLike, speed: ArrayLike, tau: ArrayLike, h: float) -> FloatArray:
    """The ``ctrl`` [m] that moves MuJoCo's rest-length activations ``l0`` [m] (a first-order
    lag of time constant ``tau`` [s], integrated exactly over a step of ``h`` [s]) towards
    ``command`` by at most ``speed h`` [m] in the step, as the project's motors' slew limit
    (which MJCF cannot hold): the activation moves ``(ctrl - l0)(1 - exp(-h / tau))`` in a step."""
    l0 = np.asarray(l0, dtype=float)
    reach = np.asarray(speed, dtype=float) * h / -np.expm1(-h / np.asarray(tau, dtype=float))
    out: FloatArray = l0 + np.clip(np.asarray(command, dtype=float) - l0, -reach, reach)
    return out


@functools.cache
def moves(spread: float) -> tuple[FloatArray, FloatArray]:
    """``(nominal, targets)`` [m]: the actuated cables' nominal rest lengths and the 8 tipping
    moves of ``six_bar_roll``'s derivation towards +x with ``spread``
    (:func:`tensegrity_core.robot.tipping.tipping_steps`; 1: the fewest cables, as every
    layout but the shipped one was measured; the shipped gait: ``GAIT_SPREAD``), rounded to
    1 um as the gait file is."""
    robot = load_scene("six_bar_roll").model.robot
    act = robot.cables.actuated
    nominal = robot.cables.rest_length[act]
    targets = []
    for step in tipping_steps(robot, 8, (1.0, 0.0), spread):
        target = nominal.copy()
        for j, r in zip(step.cables, step.rest_lengths):
            target[int(np.flatnonzero(act == j)[0])] = r
        targets.append(np.round(target, 6))
    return nominal, np.array(targets)


def laid_out(hold: float, rest: float | None, overlap: bool = False, spread: float = 1.0) -> Gait:
    """``six_bar_roll``'s tipping moves derived with ``spread`` (:func:`moves`) laid out: per
    tip the move (at the motors' speed x 1.2, as
    :func:`tensegrity_core.robot.tipping.gait_of_steps` moves), a hold of ``hold`` [s], then
    the release to the nominal rest lengths and a rest of ``rest`` [s] (the shipped layout:
    ``(0.5, 0.3)`` with ``spread`` 3); ``rest=None``: no release between tips (each move
    starts from the last tip's rest lengths), one release at the end. ``overlap``: the
    release leaves the cables the next move drives where they are held (they go straight to
    their next target in the next move)."""
    robot = load_scene("six_bar_roll").model.robot
    shipped = gait_from_file(GAITS_DIR / "six_bar_roll.yaml")
    nominal, targets = moves(spread)
    speed = robot.motors.max_speed
    times, table = [0.0], [nominal]

    def move_to(row: FloatArray, then: float | None) -> None:
        times.append(times[-1] + max(0.05, 1.2 * float(np.max(np.abs(row - table[-1]) / speed))))
        table.append(row)
        if then:
            times.append(times[-1] + then)
            table.append(row)

    for k, target in enumerate(targets):
        move_to(target, hold)
        if rest is not None and overlap and k + 1 < len(targets):
            driven = targets[k + 1] != nominal
            move_to(np.where(driven, target, nominal), rest)
        elif rest is not None:
            move_to(nominal, rest)
    if rest is None:
        move_to(nominal, None)
    return Gait(name="six_bar_roll", cables=shipped.cables, times=tuple(round(t, 4) for t in times),
                rest_lengths=tuple(tuple(float(v) for v in r) for r in table))


def gait_scene(layout: Layout | None, step: float = 1e-3,
               duration: float | None = None) -> Scene:
    """``six_bar_roll`` with its gait :func:`laid_out` as ``layout`` (None: as shipped), the
    integrator's fixed step ``step`` [s], simulated for ``duration`` [s] (None: the scene's
    20 s as shipped, :data:`DURATION` for the release-free layout, the gait and 1 s for
    another)."""
    scene = load_scene("six_bar_roll")
    if layout is not None:
        gait = laid_out(*layout)
        data = yaml.safe_load((SCENES_DIR / "six_bar_roll.yaml").read_text(encoding="utf-8"))
        data["inputs"] = {"gait": {k: v for k, v in gait_to_dict(gait).items() if k != "name"}}
        scene = load_scene(data).with_duration(DURATION if layout == RELEASE_FREE else gait.duration + 1.0)
    if duration is not None:
        scene = scene.with_duration(duration)
    return dataclasses.replace(scene, integrator=dataclasses.replace(scene.integrator, max_step=step))


@dataclass
class Run:
    """A MuJoCo run: the faces reached ``(t [s], caps)`` (as play_gait counts them), the
    robot's centre of mass at the start and the end [m], and with a controller the faces it
    rolled to (node indices) and the time it ended [s]."""

    faces: list[tuple[float, str]]
    com: tuple[np.ndarray, np.ndarray]
    visited: list[tuple[int, ...]]
    t_end: float


def run(scene_name: str = "six_bar_roll", *, law: FloorLaw | None = None, integrator: str = "RK4",
        timestep: float = 1e-3, duration: float | None = None, roll: int = 0, slew: bool = False,
        layout: Layout | None = RELEASE_FREE) -> Run:
    """MuJoCo on the export of ``scene_name`` driven by the gait ``six_bar_roll`` (``roll = 0``;
    :func:`laid_out` as ``layout``, None: as shipped) or by the closed-loop controller asked
    for ``roll`` faces towards +x (sampled at 50 Hz, stopped 1 s after it is done), with its
    own contacts (``law=None``) or the project's floor law (``law``), for ``duration`` [s]
    (:func:`gait_scene`'s for a gait). ``slew``: each motor's command limited at every step
    so that its rest length moves at most ``max_speed h`` (the project's slew limit, which
    the export leaves out: :func:`slew_limited`)."""
    if roll:
        scene = load_scene(scene_name).with_duration(duration or DURATION)
    else:
        scene = gait_scene(layout, duration=duration)
    duration = scene.duration
    robot = scene.model.robot
    m = mujoco.MjModel.from_xml_string(export_mjcf(scene, integrator=integrator, timestep=timestep).xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    floor, F_n = None, None
    try:
        if law is not None:
            names = [robot.node_names[int(i)] for i in robot.rods.ends.ravel()]
            floor = ProjectFloor(scene_floor(scene), names, law)
            F_n = floor.attach(m, d)
        mujoco.mj_forward(m, d)
        weight = float(np.sum(m.body_mass) * np.linalg.norm(m.opt.gravity))
        if roll:
            controller = RollController(robot, roll, heading=(1.0, 0.0))
            cables = [robot.cables.names[j] for j in robot.cables.actuated]
            every, finish = round(PERIOD / timestep), math.inf
        else:
            gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml") if layout is None else laid_out(*layout)
            t_table, v_table = gait.table()
            cables = list(gait.cables)
        motors = np.array([m.actuator(f"cable:{c}").id for c in cables])
        by_cable = {robot.cables.names[int(c)]: j for j, c in enumerate(robot.motors.cable)}
        speed = np.array([robot.motors.max_speed[by_cable[c]] for c in cables])
        tau = np.array([robot.motors.tau[by_cable[c]] for c in cables])
        act = m.actuator_actadr[motors]
        command = d.ctrl[motors].copy()
        index = {n: i for i, n in enumerate(robot.node_names)}
        faces: list[tuple[float, str]] = []
        com0 = d.subtree_com[0].copy()
        for k in range(round(duration / timestep) + 1):
            if floor is None:
                caps = touching_caps(m, d, min_force=SHARE * weight)
            else:
                caps = frozenset(n for n, f in zip(floor.names, F_n) if f > SHARE * weight)
            face = " ".join(sorted(caps, key=lambda c: int(c[1:])))
            if len(caps) == 3 and (not faces or faces[-1][1] != face):
                faces.append((d.time, face))
            if not roll:
                command = [np.interp(d.time, t_table, v_table[:, j]) for j in range(len(motors))]
            elif k % every == 0:
                touching = (touching_caps(m, d) if floor is None
                            else frozenset(n for n, f in zip(floor.names, F_n) if f > 0))
                nodes = np.array([d.site(f"node:{n}").xpos for n in robot.node_names])
                command = controller.update(d.time, sorted(index[c] for c in touching), nodes)
                if controller.done and finish == math.inf:
                    finish = d.time + 1.0
                if d.time >= finish:
                    break
            d.ctrl[motors] = slew_limited(command, d.act[act], speed, tau, timestep) if slew else command
            mujoco.mj_step(m, d)
            if floor is not None:
                F_n = floor.step_end(d)
        mujoco.mj_forward(m, d)
        return Run(faces, (com0, d.subtree_com[0].copy()), list(controller.visited) if roll else [], d.time)
    finally:
        ProjectFloor.detach()


def project(scene_name: str = "six_bar_roll", *, step: float = 1e-3, duration: float | None = None,
            roll: int = 0, layout: Layout | None = RELEASE_FREE) -> Run:
    """The project's run of the same experiment (:func:`run`'s arguments; ``step`` [s] the
    scene's fixed step): the gait's scene simulated, or the controller run by
    :class:`~tensegrity_core.sim.control_loop.ControlLoop`; faces counted as :func:`run`
    counts them, at the samples (100 Hz for the gait, the controller's 50 Hz). With a rest
    between tips, prints the kinetic energy [J] at the start of each next move and its peak
    since the last move's start."""
    if roll:
        scene = load_scene(scene_name).with_duration(duration or DURATION)
        scene = dataclasses.replace(scene, integrator=dataclasses.replace(scene.integrator, max_step=step))
    else:
        scene = gait_scene(layout, step, duration)
    duration = scene.duration
    robot = scene.model.robot
    visited: list[tuple[int, ...]] = []
    if roll:
        model = compile_scene(scene)
        controller = RollController(robot, roll, heading=(1.0, 0.0))
        seen = model.observe(ControlLoop(model, model.initial_state(t_end=duration), controller,
                                         rate=1 / PERIOD).run(duration, after=1.0))
        times, forces, nodes, visited = seen["t"], seen["contact_forces"], seen["nodes"], controller.visited
        rolled = rigid_roll(nodes[0], visited, float(robot.rods.cap_radius.max()))
        print(f"  the rigid start shape rolled over the same edges: its centre moves ({rolled[-1, 0]:.2f}, "
              f"{rolled[-1, 1]:.2f}) m, per tip {np.round(np.hypot(*np.diff(rolled, axis=0).T), 2)} m", flush=True)
    else:
        out = simulate(scene)
        times, forces, nodes = out.times, np.asarray(out.contact_forces), np.asarray(out.nodes)
        gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml") if layout is None else laid_out(*layout)
        if layout is None or layout[1] is not None:
            moves = np.asarray(gait.times)[::4]                     # nominal, then move, hold, release, rest
            K = np.asarray(out.kinetic_energy)
            left = [(float(K[(times >= a) & (times <= b)].max()), float(np.interp(b, times, K)))
                    for a, b in zip(moves[:-2], moves[1:-1])]
            print("  kinetic energy at each next move [J] (peak since the last move's start): "
                  + ", ".join(f"{k:.2f} ({p:.1f})" for p, k in left), flush=True)
    mid = 0.5 * (nodes[:, robot.rods.ends[:, 0]] + nodes[:, robot.rods.ends[:, 1]])
    com = np.einsum("r,trk->tk", robot.rods.mass, mid) / robot.rods.mass.sum()     # the rods' centre of mass
    weight = robot.total_mass() * float(np.linalg.norm(robot.gravity))
    names = [robot.node_names[int(i)] for i in robot.rods.ends.ravel()]     # the caps' order
    faces: list[tuple[float, str]] = []
    for t, row in zip(times, forces):
        caps = [n for n, f in zip(names, row) if f > SHARE * weight]
        face = " ".join(sorted(caps, key=lambda c: int(c[1:])))
        if len(caps) == 3 and (not faces or faces[-1][1] != face):
            faces.append((float(t), face))
    return Run(faces, (com[0], com[-1]), list(visited), float(times[-1]))


def rigid_roll(nodes: np.ndarray, visited: list[tuple[int, ...]], radius: float) -> np.ndarray:
    """(faces, 2) [m]: the centre of the nodes ``nodes`` (n, 3) (equal masses: the 6-bar's
    caps) on the floor while the rigid shape rolls over the edges between the ``visited``
    faces (node indices), from the first; each tip turns the shape about the shared edge
    until the next face lies on the floor, ``radius`` [m] the caps' radius."""
    X = np.asarray(nodes, dtype=float)
    out = [X.mean(axis=0)[:2]]
    for F, G in zip(visited, visited[1:]):
        a, b = sorted(set(F) & set(G))
        face = next(f for f in hull_faces(X) if set(f) == set(G))     # outward-ordered
        Y = place_on_face(X, face, radius)
        # turned about the vertical and moved so that the shared edge's caps stay where they are
        turn = math.atan2(*(X[b, 1::-1] - X[a, 1::-1])) - math.atan2(*(Y[b, 1::-1] - Y[a, 1::-1]))
        c, s = math.cos(turn), math.sin(turn)
        Y = Y @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
        Y[:, :2] += X[a, :2] - Y[a, :2]
        X = Y
        out.append(X.mean(axis=0)[:2])
    return np.array(out) - out[0]


def show(label: str, out: Run, since: float = FROM) -> None:
    travel = out.com[1] - out.com[0]
    faces = ", ".join(f"{f} ({t:.2f})" for t, f in out.faces if t >= since or out.visited)
    print(f"{label}: {faces}; centre of mass moved ({travel[0]:.2f}, {travel[1]:.2f}) m"
          + (f", rolled to {out.visited[1:]} by {out.t_end:.2f} s" if out.visited else ""), flush=True)


#: The four runs that decide whether a layout is decisive.
FOUR_WAYS: tuple[tuple[str, dict[str, object]], ...] = (
    ("project, RK4 1 ms", dict(project=True)), ("project, RK4 0.25 ms", dict(project=True, step=2.5e-4)),
    ("MuJoCo, RK4 1 ms", {}), ("MuJoCo, RK4 0.5 ms", dict(timestep=5e-4)))

EXPERIMENTS = {
    "project, RK4 1 ms": dict(project=True),
    "project, RK4 0.5 ms": dict(project=True, step=5e-4),
    "project, RK4 0.25 ms": dict(project=True, step=2.5e-4),
    "closed loop, 4 faces: project": dict(project=True, scene_name="six_bar_rest", roll=4, duration=30.0),
    "MuJoCo as exported before (implicitfast)": dict(integrator="implicitfast"),
    "MuJoCo, RK4 (as exported)": dict(),
    "MuJoCo, RK4, the project's floor law": dict(law=FloorLaw()),
    "MuJoCo, implicitfast, 0.5 ms": dict(integrator="implicitfast", timestep=5e-4),
    "MuJoCo, implicitfast, 0.25 ms": dict(integrator="implicitfast", timestep=2.5e-4),
    "MuJoCo, implicitfast, 0.1 ms": dict(integrator="implicitfast", timestep=1e-4),
    "MuJoCo, RK4, 0.5 ms": dict(timestep=5e-4),
    "MuJoCo, RK4, 0.9 ms": dict(timestep=9e-4),
    "MuJoCo, RK4, 1.1 ms": dict(timestep=1.1e-3),
    "MuJoCo, RK4, the project's law, linear normal force": dict(law=FloorLaw(normal="linear")),
    "MuJoCo, RK4, the project's law, regularised friction": dict(law=FloorLaw(friction="regularised")),
    "MuJoCo, RK4, the project's law without the couples": dict(law=FloorLaw(couples=False)),
    "closed loop, 4 faces: MuJoCo, RK4": dict(scene_name="six_bar_rest", roll=4, duration=30.0),
    "closed loop, 4 faces: MuJoCo, implicitfast": dict(scene_name="six_bar_rest", roll=4, duration=30.0,
                                                       integrator="implicitfast"),
    "closed loop, 4 faces: MuJoCo, RK4, the project's floor law": dict(scene_name="six_bar_rest", roll=4,
                                                                       duration=30.0, law=FloorLaw()),
    "closed loop, 4 faces: MuJoCo, RK4, the project's law, regularised friction": dict(
        scene_name="six_bar_rest", roll=4, duration=30.0, law=FloorLaw(friction="regularised")),
    "closed loop, 4 faces: MuJoCo, RK4, the motors' slew limit": dict(scene_name="six_bar_rest", roll=4,
                                                                     duration=30.0, slew=True),
    "closed loop, 4 faces: MuJoCo, RK4, the project's floor law and slew limit": dict(
        scene_name="six_bar_rest", roll=4, duration=30.0, law=FloorLaw(), slew=True),
    "MuJoCo, RK4, the motors' slew limit": dict(slew=True),
    # the shipped layout (release and rest between tips) and others, every face from the start
    "shipped: project, RK4 1 ms": dict(project=True, layout=None),
    "shipped: project, RK4 0.5 ms": dict(project=True, layout=None, step=5e-4),
    "shipped: project, RK4 0.25 ms": dict(project=True, layout=None, step=2.5e-4),
    "shipped: MuJoCo, RK4 1 ms": dict(layout=None),
    "shipped: MuJoCo, RK4 0.5 ms": dict(layout=None, timestep=5e-4),
    **{f"hold {h} s, rest {r} s: {who}": dict(layout=(h, r), **options)
       for h, r in ((0.2, 0.5), (0.3, 0.3), (0.4, 0.4), (0.6, 0.6), (0.4, 0.1), (0.4, 0.2), (0.9, None))
       for who, options in FOUR_WAYS},
    **{f"hold {h} s, release the cables the next move does not drive, rest {r} s: {who}": dict(
        layout=(h, r, True), **options) for h, r in ((0.6, 0.1), (0.4, 0.1)) for who, options in FOUR_WAYS},
    **{f"hold 0.6 s, rest 0.3 s: {who}": dict(layout=(0.6, 0.3), **options) for who, options in FOUR_WAYS},
    # the moves shared among more cables (tipping's spread), shorter at the motors' slew limit
    **{f"spread {p}, hold {h} s, rest {r} s: {who}": dict(layout=(h, r, False, p), **options)
       for p, h, r in ((3.0, 0.6, 0.3), (3.0, 0.4, 0.3), (3.0, 0.4, 0.4), (3.0, 0.45, 0.3), (3.0, 0.55, 0.3),
                       (3.0, 0.5, 0.25), (3.0, 0.5, 0.35), (2.5, 0.5, 0.3), (3.5, 0.5, 0.3), (100.0, 0.5, 0.3))
       for who, options in FOUR_WAYS},
}

def _inverse_rate(psi: float, psi0: float, w0: float) -> float:
    """``dt / dpsi`` [s/rad] of a body turning about an edge from rest at ``psi0`` [rad]
    beyond the vertical, ``psi'' = w0^2 sin psi``."""
    return 1.0 / math.sqrt(2 * w0 ** 2 * (math.cos(psi0) - math.cos(psi)))


def tip_budget() -> None:
    """What a tip of ``six_bar_roll``'s derivation takes ("A decisive roll", "What a tip's
    time is made of"), for its three kinds of step (off a closed face, off an open face over
    its long and over its short edge) with the fewest cables and with ``GAIT_SPREAD``: the
    longest travel [m] and the move's time at the motors' slew limit (x 1.2, as laid out)
    [s]; and the rest shape turning rigidly about the edge, from rest with its centre of mass
    the derived margin beyond it, onto the next face: ``I_e psi'' = M g d sin psi`` (``d``
    [m] the centre of mass's distance from the edge, ``I_e`` [kg m^2] the rods' inertia about
    it): the time is the quadrature of ``1 / psi'`` from energy conservation."""
    from scipy.integrate import quad

    from tensegrity_core.robot.statics import rest_shape
    from tensegrity_core.robot.tipping import GAIT_SPREAD

    robot = load_scene("six_bar_roll").model.robot
    X = rest_shape(robot).nodes
    mass = robot.lumped_masses()
    M, g = float(mass.sum()), float(np.linalg.norm(robot.gravity))
    speed = float(robot.motors.max_speed.min())
    nominal = robot.cables.rest_length
    for spread in (1.0, GAIT_SPREAD):
        for step in tipping_steps(robot, 3, (1.0, 0.0), spread):
            P = place_on_face(X, step.face, float(robot.rods.cap_radius.max()))
            a, _, c = step.face
            if P[c, 1] < 0:
                P = P * np.array([1.0, -1.0, 1.0])
            edge = P[a, 1:]                                     # (y, z) of the edge, seen along it
            d = float(np.linalg.norm((mass @ P / M)[1:] - edge))
            p, q = P[robot.rods.ends[:, 0], 1:] - edge, P[robot.rods.ends[:, 1], 1:] - edge
            inertia = float(np.sum(robot.rods.mass / 3 * np.sum(p * p + p * q + q * q, axis=1)))
            far = P[next(i for i in step.next_face if i not in step.edge), 1:] - edge
            turn = math.pi - abs(math.atan2(far[1], far[0]))    # onto the next face [rad]
            w0 = math.sqrt(M * g * d / inertia)
            psi0 = math.asin(-step.margin_after / d)
            fall = quad(_inverse_rate, psi0, psi0 + turn, args=(psi0, w0), limit=200)[0]
            travel = float(np.max(np.abs(np.asarray(step.rest_lengths) - nominal[list(step.cables)])))
            print(f"spread {spread:g}, {' '.join(robot.node_names[i] for i in step.face)} over "
                  f"{' '.join(robot.node_names[i] for i in step.edge)}: {len(step.cables)} cables, travel "
                  f"{travel:.3f} m, move {1.2 * travel / speed:.2f} s; d {d:.3f} m, I_e {inertia:.1f} kg m^2, "
                  f"1/omega_0 {1 / w0:.3f} s, from {math.degrees(psi0):.2f} deg beyond the edge a rigid fall of "
                  f"{math.degrees(turn):.1f} deg takes {fall:.2f} s")


if __name__ == "__main__":
    chosen = sys.argv[1:] or list(EXPERIMENTS)
    for label in chosen:
        if label == "tip budget":
            tip_budget()
            continue
        options = dict(EXPERIMENTS[label])
        since = FROM if options.get("layout", RELEASE_FREE) == RELEASE_FREE else 0.0
        show(label, project(**options) if options.pop("project", False) else run(**options), since)
