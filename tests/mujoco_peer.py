"""MuJoCo as an independent peer of the general dynamics and the robots: runs an exported MJCF model.

Needs the ``mujoco`` extra (``./run setup`` installs it). Only MuJoCo computes here: the
model is the document of ``tensegrity export mjcf`` (:func:`tensegrity_core.export.export_mjcf`),
read back by MuJoCo's own parser, and every number this module returns comes from
MuJoCo's state (the project's structure is used only to translate a state vector of the
general dynamics into MuJoCo's coordinates, :func:`mujoco_state`). Use::

    from tests.mujoco_peer import MujocoPeer
    peer = MujocoPeer(export_mjcf(scene).xml, timestep=1e-4)   # or a path to model.xml
    run = peer.rollout(times)              # from the keyframe 'initial' (the scene's initial state)
    run.nodes        # (N, n, 3) [m] node positions at times[k], nodes in the structure's order
    run.kinetic      # (N,) [J]
    run.potential    # (N,) [J] springs, gravity, dead loads, actuator members (see below)

``MujocoPeer(model, *, timestep=None, integrator=None)``
    ``model``: MJCF text or a path. ``timestep`` [s] and ``integrator`` (``"RK4"``,
    ``"Euler"``, ``"implicit"``, ``"implicitfast"``) override the model's ``<option>``.
    ``node_names``: the nodes (the ``node:`` sites) in the document's order (pinned nodes,
    free nodes, then each body's); :meth:`rollout` returns them in the order of its
    ``nodes=`` argument (e.g. ``structure.node_names``), or this one.
``peer.reset(qpos=None, qvel=None)``
    Back to the keyframe ``initial`` at ``t = 0``, or to the given coordinates.
``peer.rollout(times, *, nodes=None, controls=None) -> PeerRun``
    From the current state (``t = 0`` after :meth:`reset`), steps to each of ``times`` [s]
    (increasing, each a whole number of steps from the last, to 1e-9 of a step) and samples
    the state there. ``controls(t) -> ctrl`` (the model's ``nu`` values), if given, is
    applied at the start of every step (zero-order hold over a step; the keyframe's
    ``ctrl`` otherwise). Returns a :class:`PeerRun`: ``times``, ``nodes`` (N, n, 3),
    ``kinetic`` and ``potential`` (N,) [J], ``steps`` (MuJoCo steps taken), ``wall``
    (seconds of ``mj_step`` only, for benchmarks).
``mujoco_state(peer, structure, y, R_ref) -> (qpos, qvel)``
    A state ``y = (x, v)`` of the general dynamics (``GeneralDynamic.state_from``'s vector:
    coordinates in the rotation charts ``R_ref`` (nb, 3, 3), rates with world angular
    velocities) in MuJoCo's coordinates (slide joints relative to the body's position in
    the model, free joints: the frame's origin -- the centre, or the centre of mass where
    the export moved the frame there (docs/mujoco.md) --, quaternion ``w x y z``, the
    origin's velocity, angular velocity in the body frame).

**Energies.** ``kinetic`` is MuJoCo's ``energy[1]``. ``potential`` is MuJoCo's
``energy[0]`` (gravity on the body masses, ``-m g . x_com``, and the tendon springs, zero
inside a string's dead band) plus what MuJoCo's energy leaves out: each dead load's
``-F . x`` at its site, and each actuator member's ``EA (l - l0)^2 / (2 l0)`` (from the
actuator's gain and bias, its ``ctrl`` and the tendon's length). It equals the general
dynamics' potential energy up to a constant (MuJoCo leaves out the weights of pinned nodes):
compare differences over time.

**Robots** (a model of ``export_mjcf(robot)``, see docs/mujoco.md "Robots"):

``robot_real_time_factor(model, seconds, *, timestep=1e-3, repeats=3) -> float``
    Simulated seconds per wall-clock second of MuJoCo stepping the exported robot from its
    keyframe ``initial`` (motors holding their drawn rest lengths, gravity and the floor as
    exported) for ``seconds`` [s] at ``timestep`` [s] with the model's integrator, on one
    core (MuJoCo's ``mj_step`` is single-threaded). Only ``mj_step`` is timed; the best of
    ``repeats`` runs (the least disturbed by other processes). For the robots benchmark
    (``tests/bench/bench_robots.py``): call it beside the project's run of the same robot
    and report the ratio.
``touching_caps(model, data, *, min_force=0) -> frozenset[str]``
    The end caps (node names) pressed on the floor by more than ``min_force`` [N] in
    MuJoCo's current state.
``play_gait(model, gait, duration, *, sample=0.01, share=0.02) -> GaitRun``
    The robot from its keyframe with the gait's rest lengths as the motors' controls (the
    gait's table interpolated at the start of every step), for ``duration`` [s]: the
    centre of mass every ``sample`` [s] and the faces it stood on, in order
    (:class:`GaitRun`): a face is a set of exactly three caps each carrying more than
    ``share`` of the robot's weight, checked at every step (a cap grazing the floor while
    the robot tips carries less).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.general.rotation import exp_so3
from tensegrity_core.general.structure import Structure
from tensegrity_core.robot.gait import Gait

FloatArray = NDArray[np.float64]
NODE = "node:"


@dataclass
class PeerRun:
    """Samples of a MuJoCo run: ``times`` (N,) [s], ``nodes`` (N, n, 3) [m], ``kinetic`` and
    ``potential`` (N,) [J]; ``steps`` MuJoCo steps taken, ``wall`` [s] spent in them."""

    times: FloatArray
    nodes: FloatArray
    kinetic: FloatArray
    potential: FloatArray
    steps: int
    wall: float


class MujocoPeer:
    """An exported model compiled by MuJoCo, with its data (see the module docstring)."""

    def __init__(self, model: str | Path, *, timestep: float | None = None, integrator: str | None = None):
        text = Path(model).read_text(encoding="utf-8") if isinstance(model, Path) else model
        self.model = mujoco.MjModel.from_xml_string(text)
        m = self.model
        if timestep is not None:
            m.opt.timestep = timestep
        if integrator is not None:
            m.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
        m.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
        self.data = mujoco.MjData(m)
        sites = [(m.site(k).name, k) for k in range(m.nsite)]
        self.site_of = {name.removeprefix(NODE): k for name, k in sites if name.startswith(NODE)}
        self.node_names = tuple(self.site_of)
        tendon = m.actuator_trntype == mujoco.mjtTrn.mjTRN_TENDON
        site = m.actuator_trntype == mujoco.mjtTrn.mjTRN_SITE
        self._members = np.flatnonzero(tendon)
        self._loads = np.flatnonzero(site)
        self.reset()

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def reset(self, qpos: ArrayLike | None = None, qvel: ArrayLike | None = None) -> None:
        """The keyframe ``initial`` at ``t = 0``, or the given coordinates (``ctrl`` from the keyframe)."""
        m, d = self.model, self.data
        mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
        if qpos is not None:
            d.qpos[:] = qpos
        if qvel is not None:
            d.qvel[:] = qvel
        mujoco.mj_forward(m, d)

    def potential(self) -> float:
        """The potential energy [J] of the current state (after ``mj_forward``; see the module docstring)."""
        m, d = self.model, self.data
        V = float(d.energy[0])
        for a in self._loads:
            force = m.actuator_biasprm[a, 0] * m.actuator_gear[a, :3]
            V -= float(force @ d.site_xpos[m.actuator_trnid[a, 0]])
        for a in self._members:
            EA, k_ref = m.actuator_biasprm[a, 0], m.actuator_gainprm[a, 1]
            l0 = EA / k_ref / (1.0 - d.ctrl[a])
            V += 0.5 * EA * (d.ten_length[m.actuator_trnid[a, 0]] - l0) ** 2 / l0
        return V

    def rollout(self, times: ArrayLike, *, nodes: Sequence[str] | None = None,
                controls: Callable[[float], ArrayLike] | None = None) -> PeerRun:
        m, d = self.model, self.data
        ts = np.asarray(times, dtype=float)
        dt = self.timestep
        sites = np.array([self.site_of[n] for n in (nodes if nodes is not None else self.node_names)])
        out_nodes = np.empty((len(ts), len(sites), 3))
        kinetic, potential = np.empty(len(ts)), np.empty(len(ts))
        steps, wall = 0, 0.0
        for k, t in enumerate(ts):
            n = (t - d.time) / dt
            if abs(n - round(n)) > 1e-9 * max(1.0, abs(n)) or round(n) < 0:
                raise ValueError(f"t = {t!r} s is not a whole number of {dt!r} s steps after {d.time!r} s")
            n = round(n)
            start = time.perf_counter()
            if controls is None:
                if n:
                    mujoco.mj_step(m, d, nstep=n)
            else:
                for _ in range(n):
                    d.ctrl[:] = controls(d.time)
                    mujoco.mj_step(m, d)
            wall += time.perf_counter() - start
            steps += n
            d.time = t                    # no drift of the clock over many steps
            mujoco.mj_forward(m, d)
            out_nodes[k] = d.site_xpos[sites]
            kinetic[k] = d.energy[1]
            potential[k] = self.potential()
        return PeerRun(ts, out_nodes, kinetic, potential, steps, wall)


def _site_names(m: mujoco.MjModel) -> NDArray[np.str_]:
    return np.array([m.site(k).name for k in range(m.nsite)])


def mujoco_state(peer: MujocoPeer, structure: Structure, y: ArrayLike,
                 R_ref: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(qpos, qvel)`` of the general dynamics' state ``y`` (see the module docstring)."""
    m = peer.model
    lay = structure.layout
    y = np.asarray(y, dtype=float)
    x, v = y[:lay.n_dof], y[lay.n_dof:]
    R_ref = np.asarray(R_ref, dtype=float)
    qpos, qvel = np.zeros(m.nq), np.zeros(m.nv)
    for j in range(m.njnt):
        name = m.joint(j).name
        qa, va = m.jnt_qposadr[j], m.jnt_dofadr[j]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
            node, axis = name.removeprefix(NODE).rsplit(":", 1)
            i, a = structure.node_index(node), "xyz".index(axis)
            u = lay.free_index[i, a]
            qpos[qa] = x[u] - m.body_pos[m.jnt_bodyid[j], a]
            qvel[va] = v[u]
        else:
            slot = lay.body_names.index(name.removeprefix("body:"))
            u = lay.body_dof[slot]
            R = exp_so3(x[u + 3:u + 6]) @ R_ref[slot]
            body = m.jnt_bodyid[j]                # its frame: the node centroid, moved by the sites' mean
            shift = -m.site_pos[(m.site_bodyid == body) & np.char.startswith(_site_names(m), NODE)].mean(axis=0)
            qpos[qa:qa + 3] = x[u:u + 3] + R @ shift
            qpos[qa + 3:qa + 7] = Rotation.from_matrix(R).as_quat(scalar_first=True)
            qvel[va:va + 3] = v[u:u + 3] + np.cross(v[u + 3:u + 6], R @ shift)
            qvel[va + 3:va + 6] = R.T @ v[u + 3:u + 6]
    return qpos, qvel


# -- robots ----------------------------------------------------------------------------------------
CAP = "cap:"



def body_force_expectation(m: mujoco.MjModel, d: mujoco.MjData, body: int, nodal: NDArray[np.float64],
                           rounding: NDArray[np.float64], arm_from: NDArray[np.float64], size: float
                           ) -> tuple[int, NDArray[np.float64], NDArray[np.float64]]:
    """What MuJoCo's generalized force on the free joint of ``body`` must be when the nodes
    riding on it feel the forces ``nodal`` (k, 3) [N] at ``arm_from`` (k, 3) [m]: its first
    dof index, the expected (6,) force [N] and moment about the body's frame origin in the
    body frame [N m], and their allowance from the forces' ``rounding`` (k,) [N] and the
    model's ``size`` [m] (moments carry 64 eps of size times the forces)."""
    eps = float(np.finfo(float).eps)
    v = int(m.jnt_dofadr[m.body_jntadr[body]])
    arm = arm_from - d.xpos[body]
    R = d.xmat[body].reshape(3, 3)
    expected, tolerance = np.empty(6), np.empty(6)
    expected[:3] = nodal.sum(axis=0)
    expected[3:] = R.T @ np.cross(arm, nodal).sum(axis=0)
    tolerance[:3] = rounding.sum()
    tolerance[3:] = (rounding * (1.0 + np.linalg.norm(arm, axis=1))).sum() + 64 * eps * size * np.abs(nodal).sum()
    return v, expected, tolerance


def robot_real_time_factor(model: str | Path, seconds: float, *, timestep: float = 1e-3, repeats: int = 3) -> float:
    """Simulated seconds per wall-clock second of MuJoCo stepping an exported robot (module docstring)."""
    text = Path(model).read_text(encoding="utf-8") if isinstance(model, Path) else model
    m = mujoco.MjModel.from_xml_string(text)
    m.opt.timestep = timestep
    d = mujoco.MjData(m)
    n = max(1, round(seconds / timestep))
    best = math.inf
    for _ in range(repeats):
        mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
        start = time.perf_counter()
        mujoco.mj_step(m, d, nstep=n)
        best = min(best, time.perf_counter() - start)
    return n * timestep / best


def touching_caps(m: mujoco.MjModel, d: mujoco.MjData, *, min_force: float = 0.0) -> frozenset[str]:
    """The end caps (node names, without ``cap:``) pressed on the floor now by more than
    ``min_force`` [N]."""
    out = set()
    wrench = np.zeros(6)
    for c in range(d.ncon):
        mujoco.mj_contactForce(m, d, c, wrench)
        if wrench[0] <= min_force:
            continue
        for g in d.contact[c].geom:
            name = m.geom(g).name
            if name.startswith(CAP):
                out.add(name.removeprefix(CAP))
    return frozenset(out)


@dataclass
class GaitRun:
    """A gait played into MuJoCo: ``times`` (N,) [s], ``com`` (N, 3) [m] the robot's centre
    of mass, ``faces`` the faces it stood on in order as ``(t [s], caps)``, ``t`` when it
    reached each (:func:`play_gait`)."""

    times: FloatArray
    com: FloatArray
    faces: list[tuple[float, frozenset[str]]]


def play_gait(model: str | Path, gait: Gait, duration: float, *, sample: float = 0.01,
              share: float = 0.02) -> GaitRun:
    """The robot driven by ``gait`` in MuJoCo (module docstring)."""
    text = Path(model).read_text(encoding="utf-8") if isinstance(model, Path) else model
    m = mujoco.MjModel.from_xml_string(text)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    mujoco.mj_forward(m, d)
    weight = float(np.sum(m.body_mass) * np.linalg.norm(m.opt.gravity))
    t_table, v_table = gait.table()
    motors = np.array([m.actuator(f"cable:{c}").id for c in gait.cables])
    every = max(1, round(sample / m.opt.timestep))
    n = round(duration / m.opt.timestep)
    times, com = [], []
    faces: list[tuple[float, frozenset[str]]] = []
    for k in range(n + 1):
        if k % every == 0:
            times.append(d.time)
            com.append(d.subtree_com[0].copy())
        caps = touching_caps(m, d, min_force=share * weight)
        if len(caps) == 3 and (not faces or faces[-1][1] != caps):
            faces.append((d.time, caps))
        if k == n:
            break
        d.ctrl[motors] = [np.interp(d.time, t_table, v_table[:, j]) for j in range(len(motors))]
        mujoco.mj_step(m, d)
    return GaitRun(np.array(times), np.array(com), faces)
