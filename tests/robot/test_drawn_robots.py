"""Physical invariants of robots drawn by hypothesis over the description's accepted ranges,
not the shipped robots: one to three rods (any length, mass, cap share, radii), one to five
cables between any of their caps (any stiffness, damping, rest length, half of them motor
driven with any lag, slew and tension limits), a floor of any orientation and contact and
friction parameters, gravity of any direction and 0.1 to 30 m/s^2. Every size is drawn
log-uniformly over twelve orders of magnitude around its unit (1e-6 to 1e6, except where the
field bounds it), and states are drawn around the drawing (moved, turned, moving, caps in and
out of the floor, anchored sticking and slipping).

At every evaluated state, in both kernel families:

- cables never push and a slack cable (``l <= l0``, also ``l = 0``) exerts nothing; no
  tension exceeds its motor's limit;
- the floor never pulls (no normal force out of contact), friction never exceeds ``mu F_n``
  (``mu_s`` sticking, ``mu_k`` slipping) and the resisting couples ``b F_n``;
- Newton: the linear momentum changes by gravity and the floor's forces alone (cables are
  internal);
- frame invariance: the robot, its floor and gravity moved by a rigid motion give the moved
  forces (nodal, friction, couples) and the same tensions and contact forces.

Over time: with gravity, floor and motors off, a drawn robot's linear momentum is conserved
to rounding through a run (the cables' forces cancel at every stage, and RK4 keeps linear
invariants exactly). A rod at rest on a floor of any orientation, gravity along the floor's
normal, reads ``g`` away from the floor on its IMU. Motors in any mode and command never
leave their range, slew faster than their limit (but when back-driven) or hold more than
their tension limit.
"""

from __future__ import annotations

import os
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tensegrity_core.general.rotation import exp_so3
from tensegrity_core.robot.contact import SPIN_TOLERANCE
from tensegrity_core.sim import compile_scene, load_scene
from tensegrity_core.sim.general.kernels.jit import KERNELS_VARIABLE, have_numba
from tensegrity_core.sim.general.robot.loops import NO_ANCHOR, SLIPPING, STICKING
from tensegrity_core.sim.general.robot.system import RobotSystem
from tests.robot.test_dynamics import _momentum_rates

KERNELS = ["numpy", "numba"] if have_numba() else ["numpy"]
ALL = ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"]


def _size(lo: float = 1e-6, hi: float = 1e6):
    """A positive size drawn log-uniformly in [lo, hi] (its unit's orders of magnitude alike)."""
    return st.floats(np.log10(lo), np.log10(hi)).map(lambda e: float(10.0 ** e))


def _maybe(size, zero: float = 0.0):
    return st.one_of(st.just(zero), size)


unit = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1).map(
    lambda v: np.array(v) / np.linalg.norm(v))


@st.composite
def robots(draw, floor: bool = True) -> dict:
    """A robot description (parsed data) drawn over the accepted ranges (module docstring)."""
    n_rods = draw(st.integers(1, 3))
    nodes: dict[str, list[float]] = {}
    rods = []
    for i in range(n_rods):
        centre = np.array(draw(st.tuples(*[st.floats(-2.0, 2.0)] * 3))) + [5.0 * i, 0.0, 0.0]   # caps apart
        axis = draw(unit)
        length = draw(_size(1e-3, 1e2))
        mass = draw(_size())
        radius = draw(_maybe(_size(1e-6, 1.0)))                   # 0: a slender rod, whose caps ...
        share = draw(st.floats(0.0 if radius > 0 else 0.01, 0.5))    # ... give it its axial inertia
        rod = {"name": f"r{i}", "nodes": [f"a{i}", f"b{i}"], "mass": mass, "radius": radius,
               "cap_mass": mass * share, "cap_radius": draw(_size(1e-6, 1.0))}
        nodes[f"a{i}"] = (centre - axis * length / 2).tolist()
        nodes[f"b{i}"] = (centre + axis * length / 2).tolist()
        rods.append(rod)
    names = list(nodes)
    cables = []
    for j in range(draw(st.integers(1, 5))):
        a, b = draw(st.lists(st.sampled_from(names), min_size=2, max_size=2, unique=True))
        cable = {"name": f"c{j}", "nodes": [a, b], "stiffness": draw(_size()), "damping": draw(_maybe(_size())),
                 "rest_length_ratio": draw(st.floats(0.2, 2.0))}
        if draw(st.booleans()):
            cable["motor"] = {"range": [1e-9, 1e4], "tau": draw(_maybe(_size(1e-4, 10.0))),
                              "max_speed": draw(st.one_of(st.just(".inf"), _size(1e-3, 1e2))),
                              "max_tension": draw(st.one_of(st.just(".inf"), _size()))}
        cables.append(cable)
    out = {"name": "drawn", "nodes": nodes, "rods": rods, "cables": cables, "sensors": {"imu": "all"},
           "gravity": (draw(st.floats(0.1, 30.0)) * draw(unit)).tolist()}   # 0: the scene's standard
    if floor:
        normal = draw(unit)
        lowest = min(float(np.dot(nodes[r["nodes"][k]], normal)) - r["cap_radius"] for r in rods for k in (0, 1))
        mu_s = draw(_maybe(_size(1e-3, 10.0)))
        out["floor"] = {"normal": normal.tolist(), "point": (lowest * normal).tolist(), "stiffness": draw(_size()),
                        "dissipation": draw(_maybe(_size())), "mu_static": mu_s,
                        "mu_kinetic": mu_s * draw(st.floats(0.0, 1.0)), "tangential_stiffness": draw(_size()),
                        "tangential_damping": draw(_maybe(_size())),
                        "rolling_friction": draw(_maybe(_size(1e-6, 0.1))),
                        "torsional_friction": draw(_maybe(_size(1e-6, 0.1)))}
    return out


def model_of(robot: dict, effects=ALL, duration: float = 1.0, step: float | None = None):
    """The robot's model (``step``: default :func:`stable_step`, which the scene's check of
    the step accepts)."""
    return compile_scene(load_scene({"name": "drawn", "model": {"kind": "robot", "robot": robot},
                                     "initial": {"drawn": True}, "effects": effects, "duration": duration,
                                     "integrator": {"max_step": step or stable_step(robot)}}))


def stable_step(robot: dict) -> float:
    """A fixed step [s] that RK4 resolves for the cables and the floor of ``robot`` in the
    states :func:`drawn_state` draws and the runs from them.

    - A cable of stiffness ``k`` and damping ``c`` between caps of rods of masses ``m_a``,
      ``m_b`` moves them as a spring on the mass ``1 / (1/m_a' + 1/m_b')`` with ``1/m' <= 4/m``
      at a rod's end (a rod's transverse inertia ``I_t`` is at least ``m L^2 / 12``, so
      ``1/m + (L/2)^2 / I_t <= 4/m``).
    - Its tension ``T`` turns the rod about its centre as the rod turns (a pull at the cap,
      ``L/2`` from the centre: the rod aligning with the cable, a pendulum of ``T L / 2`` on
      ``I_t``, so ``omega^2 <= 6 T / (m L)``); ``T`` is bounded by the cable stretched to its
      drawn length plus the drawn state's moves (half the drawing's size) and both rods'
      lengths, and its damper at 10 m/s.
    - Each cap on the floor adds its normal spring and its friction anchor.
    Summed (Gershgorin) this bounds the fastest rates ``omega^2`` and ``sigma``; half the
    inverse of the larger keeps ``h omega``, ``h sigma`` well inside RK4's region (2.8 along
    either axis)."""
    nodes = {name: np.asarray(x, dtype=float) for name, x in robot["nodes"].items()}
    size = float(np.ptp(np.array(list(nodes.values())), axis=0).max()) + 1e-3
    mass, length = {}, {}
    for r in robot["rods"]:
        a, b = r["nodes"]
        for end in (a, b):
            mass[end], length[end] = r["mass"], float(np.linalg.norm(nodes[b] - nodes[a]))
    omega2 = sigma = 0.0
    for c in robot["cables"]:
        a, b = c["nodes"]
        inv = 4.0 / mass[a] + 4.0 / mass[b]
        omega2 += c["stiffness"] * inv
        sigma += c["damping"] * inv
        stretched = float(np.linalg.norm(nodes[b] - nodes[a])) + 0.5 * size + length[a] + length[b]
        tension = c["stiffness"] * stretched + c["damping"] * 10.0
        omega2 += tension * (6.0 / (mass[a] * length[a]) + 6.0 / (mass[b] * length[b]))
    floor = robot.get("floor", {})
    for r in robot["rods"]:                 # each cap on the floor: its normal spring, its friction anchor
        omega2 += 2.0 * (floor.get("stiffness", 0.0) + floor.get("tangential_stiffness", 0.0)) * 4.0 / r["mass"]
        sigma += 2.0 * floor.get("tangential_damping", 0.0) * 4.0 / r["mass"]
    return min(1e-3, 0.5 / max(np.sqrt(omega2), sigma))


def drawn_state(model, seed: int):
    """A state around the drawing: centres moved up to the rods' size, charts and rotation
    vectors turned up to ~1 rad, rates of order 1 (m/s, rad/s), motors within 10 % of their
    drawn rest lengths, every cap anchored (or not) with an offset up to its contact's size."""
    rng = np.random.default_rng(seed)
    p = model.plan
    y = model.y0.copy()
    n = p.n_dof
    size = float(np.ptp(p.base, axis=0).max()) + 1e-3
    y[:n] += rng.normal(0.0, 0.02 * size, n)
    y[n:2 * n] = rng.normal(0.0, 1.0, n)
    na, ncap = len(p.motor_cable), len(p.cap_node)
    y[2 * n:2 * n + na] *= rng.uniform(0.9, 1.1, na)
    a0 = 2 * n + na
    y[a0:a0 + 3 * ncap] = rng.normal(0.0, 1.0, 3 * ncap) * np.repeat(p.cap_radius, 3) * 0.1
    y[a0 + 3 * ncap:] = rng.choice([NO_ANCHOR, STICKING, SLIPPING], ncap)
    nb = len(p.body_dof)
    R_ref = np.array([exp_so3(rng.normal(0.0, 0.5, 3)) for _ in range(nb)]).reshape(nb, 3, 3)
    return y, R_ref


def evaluate(model, y, R_ref, kernels: str):
    return RobotSystem(model.plan, laws=model.system.laws, R_ref=R_ref, kernels=kernels).evaluate(y[None])


@settings(max_examples=60)
@given(robot=robots(), seed=st.integers(0, 2**32 - 1), kernels=st.sampled_from(KERNELS))
def test_forces_obey_their_laws_and_the_momentum_changes_by_the_external_ones_alone(robot, seed, kernels):
    model = model_of(robot)
    p = model.plan
    y, R_ref = drawn_state(model, seed)
    ev = evaluate(model, y, R_ref, kernels)
    assert np.all(np.isfinite(ev.derivative))
    T = ev.tensions[0]
    assert np.all(T >= 0.0) and np.all(T <= p.cable_t_max)
    assert np.all(T[ev.lengths[0] <= ev.rest_lengths[0]] == 0.0)          # slack: neither spring nor damper
    F_n = ev.normal[0]
    assert np.all(F_n >= 0.0) and np.all(F_n[ev.depth[0] <= 0.0] == 0.0)
    k, d, mu_s, mu_k, k_t, c_t, b_roll, b_spin = p.floor_params
    ncap = len(p.cap_node)
    state = y[-ncap:] if ncap else np.zeros(0)
    mu = np.where(state == STICKING, mu_s, np.where(state == SLIPPING, mu_k, 0.0))
    assert np.all(np.linalg.norm(ev.friction[0], axis=1) <= mu * F_n * (1 + 1e-12) + 1e-300)
    couple = ev.couple[0]
    spin = couple @ p.floor_normal
    roll = couple - spin[:, None] * p.floor_normal
    rounding = 1e-12 * np.linalg.norm(couple, axis=1)                   # of the projections onto n here
    assert np.all(np.abs(spin) <= b_spin * F_n * (1 + 1e-12) + rounding)
    assert np.all(np.linalg.norm(roll, axis=1) <= b_roll * F_n * (1 + 1e-12) + rounding)
    force, _, scale = _momentum_rates(model, y, R_ref)
    a = ev.derivative[0, p.n_dof + p.body_dof[:, None] + np.arange(3)]
    assert np.abs(force).max() <= 1e-9 * (scale + float(np.sum(p.body_mass * np.linalg.norm(a, axis=1))))


def _moved(robot: dict, Q: np.ndarray, t: np.ndarray) -> dict:
    """``robot`` moved by the rigid motion ``x -> Q x + t``, its floor and gravity with it."""
    out = dict(robot, nodes={k: (Q @ v + t).tolist() for k, v in robot["nodes"].items()},
               gravity=(Q @ robot["gravity"]).tolist())
    if "floor" in robot:
        out["floor"] = dict(robot["floor"], normal=(Q @ robot["floor"]["normal"]).tolist(),
                            point=(Q @ robot["floor"]["point"] + t).tolist())
    return out


@settings(max_examples=40)
@given(robot=robots(), seed=st.integers(0, 2**32 - 1), turn=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
       shift=st.tuples(*[st.floats(-10.0, 10.0)] * 3), kernels=st.sampled_from(KERNELS))
def test_a_rigidly_moved_robot_gives_the_moved_forces(robot, seed, turn, shift, kernels):
    """State ``y`` of the robot and the state of the moved robot that is ``y`` moved: centres
    ``Q c + t``, charts ``Q R_ref Q^T`` and rotation vectors ``Q theta`` (its bodies' drawn
    frames are turned by ``Q``), velocities, angular velocities and anchor offsets ``Q`` of
    the original's. Its node positions are the moved ones; its nodal forces (weights, cables,
    floor), friction forces and resisting couples ``Q`` of the original's; tensions, lengths,
    depths and normal forces the same."""
    Q, t = Rotation.from_rotvec(turn).as_matrix(), np.array(shift)
    model, moved = model_of(robot), model_of(_moved(robot, Q, t))
    p = model.plan
    y, R_ref = drawn_state(model, seed)
    n, na, ncap = p.n_dof, len(p.motor_cable), len(p.cap_node)
    assert len(p.free_node) == 0                                     # every node is a rod's cap
    blocks = np.concatenate([np.arange(2 * n), 2 * n + na + np.arange(3 * ncap)]).reshape(-1, 3)
    turned = y.copy()
    turned[blocks] = y[blocks] @ Q.T
    turned[p.body_dof[:, None] + np.arange(3)] += t
    a = evaluate(model, y, R_ref, kernels)
    b = evaluate(moved, turned, Q @ R_ref @ Q.T, kernels)
    # rounding: positions to 1e-12 of their size (placed from centres and turned charts),
    # velocities likewise; forces to it times the stiffest and most damping element
    X, V = np.abs(b.positions[0]).max() + np.abs(t).max(), np.abs(a.velocities[0]).max() + 1e-300
    k, d, _, _, k_t, c_t, b_roll, b_spin = p.floor_params
    stiffest = float(p.cable_k.max()) + k * (1.0 + d * V) + k_t
    damping = float(p.cable_c.max()) + k * d * max(float(a.depth[0].max(initial=0.0)), 0.0) + c_t
    dx, dv = 1e-12 * X, 1e-12 * V
    for field, rounding in (("lengths", dx), ("depth", dx), ("tensions", stiffest * dx + damping * dv),
                            ("normal", stiffest * dx + damping * dv)):
        x, z = getattr(a, field)[0], getattr(b, field)[0]
        assert np.all(np.abs(x - z) <= 1e-9 * np.abs(x).max(initial=0.0) + rounding), field
    force = stiffest * dx + damping * dv
    couple = (b_roll + b_spin) * (force + float(a.normal[0].max(initial=0.0)) * dv / SPIN_TOLERANCE)
    for field, rounding in (("positions", dx), ("forces", len(p.cable_k) * force + force), ("friction", force),
                            ("couple", couple)):
        x, z = getattr(a, field)[0], getattr(b, field)[0]
        if field == "positions":
            x = x + t @ Q                                              # moved: Q (x + Q^T t)
        np.testing.assert_allclose(z, x @ Q.T, rtol=0, atol=1e-9 * np.abs(x).max(initial=0.0) + rounding,
                                   err_msg=field)


@settings(max_examples=15)
@given(robot=robots(floor=False), seed=st.integers(0, 2**32 - 1))
def test_without_gravity_floor_and_motors_a_drawn_robot_keeps_its_linear_momentum(robot, seed):
    """Cables only (motors held, damping as drawn): 20 fixed steps (:func:`stable_step`) from a
    drawn state whose cables may go slack and taut; ``sum m v`` stays what it was to rounding of its terms."""
    h = stable_step(robot)
    model = model_of(robot, ["inertia", "cables"], duration=20 * h, step=h)
    p = model.plan
    y, _ = drawn_state(model, seed)
    n = p.n_dof
    centre = p.body_dof[:, None] + np.arange(3)
    samples: list = []
    model.record(model.state_from(y, t_end=20 * h), np.arange(0, 21) * h, samples)
    v = np.array([s[1][n + centre] for s in samples])
    assert np.all(np.isfinite(v))
    momentum = np.einsum("b,tbi->ti", p.body_mass, v)
    rounding = 1e-12 * np.einsum("b,tbi->t", p.body_mass, np.abs(v)).max() * len(v)
    assert np.abs(momentum - momentum[0]).max() <= rounding


@pytest.mark.parametrize("kernels", KERNELS)
def test_a_cable_whose_ends_meet_is_slack_and_exerts_nothing(kernels):
    """Two rods' caps passing through each other (no rod-rod contact): the cable between them
    has length 0 < l0, so it carries nothing and the state's rates stay finite."""
    robot = {"name": "meet", "nodes": {"a0": [0, 0, 0], "b0": [1, 0, 0], "a1": [1.5, 0, 0], "b1": [2.5, 0, 0]},
             "rods": [{"name": f"r{i}", "nodes": [f"a{i}", f"b{i}"], "mass": 1.0, "radius": 0.01} for i in (0, 1)],
             "cables": [{"name": "c", "nodes": ["b0", "a1"], "stiffness": 100.0, "damping": 1.0,
                         "rest_length": 0.2}]}
    model = model_of(robot, ["inertia", "cables"])
    p = model.plan
    y = model.y0.copy()
    y[p.body_dof[1]] -= 0.5                                         # rod 1's cap a1 onto rod 0's cap b0
    y[p.n_dof:2 * p.n_dof] = 1.0
    ev = evaluate(model, y, np.broadcast_to(np.eye(3), (2, 3, 3)).copy(), kernels)
    assert ev.lengths[0, 0] == 0.0 and ev.tensions[0, 0] == 0.0
    assert np.all(np.isfinite(ev.derivative)) and np.all(ev.forces == 0.0)


@settings(max_examples=30)
@given(normal=unit, heading=unit, g=st.floats(0.1, 30.0), mass=_size(), length=_size(1e-3, 1e2),
       radius=_size(1e-6, 1.0), cap_radius=_size(1e-6, 1.0), k=_size(), d=_maybe(_size()), mu=_maybe(_size(1e-3, 10.0)),
       k_t=_size(), roll=_maybe(_size(1e-6, 0.1)), kernels=st.sampled_from(KERNELS))
def test_a_rod_at_rest_on_a_floor_reads_g_away_from_the_floor(normal, heading, g, mass, length, radius, cap_radius,
                                                              k, d, mu, k_t, roll, kernels):
    """A rod lying on a floor of any orientation ``n``, gravity ``-g n``, sunk ``m g / (2 k)`` so
    that each cap's spring carries half its weight: it is at rest (no acceleration to
    rounding) and its IMU's specific force ``R^T (a - g)`` is ``g n`` turned into its frame
    (imu.py: a body at rest on the floor reads ``+|g|`` up)."""
    axis = np.cross(normal, heading)
    if np.linalg.norm(axis) < 1e-3:
        axis = np.cross(normal, [1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.cross(normal, [0.0, 1.0, 0.0])
    axis /= np.linalg.norm(axis)
    centre = cap_radius * normal
    robot = {"name": "lying", "nodes": {"a": (centre - axis * length / 2).tolist(),
                                        "b": (centre + axis * length / 2).tolist()},
             "rods": [{"name": "r", "nodes": ["a", "b"], "mass": mass, "radius": radius, "cap_radius": cap_radius}],
             "cables": [{"name": "c", "nodes": ["a", "b"], "stiffness": 1.0, "damping": 0.0,
                         "rest_length": 2.0 * length}],
             "sensors": {"imu": "all"}, "gravity": (-g * normal).tolist(),
             "floor": {"normal": normal.tolist(), "stiffness": k, "dissipation": d, "mu_static": mu,
                       "tangential_stiffness": k_t, "rolling_friction": roll}}
    with mock.patch.dict(os.environ, {KERNELS_VARIABLE: kernels}):
        model = model_of(robot)
    p = model.plan
    y = model.y0.copy()
    y[p.body_dof[0]:p.body_dof[0] + 3] -= mass * g / (2.0 * k) * normal
    obs = model.observe_now(model.state_from(y))
    n = p.n_dof
    assert np.abs(obs["state"][n:2 * n]).max() == 0.0
    # rounding: the depth is a difference of heights of the size of the drawing, 1e-15 of it
    depth = 1e-15 * (cap_radius + length + mass * g / k)
    np.testing.assert_allclose(obs["contact_forces"][0], mass * g / 2.0, rtol=1e-9, atol=k * depth)
    R = Rotation.from_quat(obs["imu_orientation"][0]).as_matrix()
    np.testing.assert_allclose(R @ obs["imu_specific_force"][0], g * normal, rtol=0,
                               atol=1e-9 * g + 2.0 * k * depth / mass)


@settings(max_examples=20)
@given(robot=robots(floor=False), seed=st.integers(0, 2**32 - 1), data=st.data())
def test_motors_stay_within_their_limits_along_a_run(robot, seed, data):
    """Each motor in a drawn mode with a drawn command inside that mode's range (a rest length
    within 50 % of its drawn one, a reel speed within its slew limit, a tension up to its
    limit), 30 steps from a drawn state: at every step the rest length stays in the motor's
    range, moves at most ``max_speed h`` unless the spool is back-driven (then to where the
    cable pulls exactly ``max_tension``, or to the range's end), and no cable pulls harder
    than its motor's limit."""
    actuated = [c for c in robot["cables"] if "motor" in c]
    modes = {c["name"]: data.draw(st.sampled_from(["rest_length", "reel_speed", "tension"])) for c in actuated}
    ends = robot["nodes"]
    inputs = {}
    for c in actuated:
        drawn = float(np.linalg.norm(np.subtract(ends[c["nodes"][1]], ends[c["nodes"][0]]))) * c["rest_length_ratio"]
        speed, t_max = (float(str(c["motor"][key]).lstrip(".")) for key in ("max_speed", "max_tension"))
        inputs[c["name"]] = {"rest_length": drawn * data.draw(st.floats(0.5, 1.5)),
                             "reel_speed": min(speed, 10.0) * data.draw(st.floats(-1.0, 1.0)),
                             "tension": min(t_max, 1e6) * data.draw(st.floats(0.0, 1.0))}[modes[c["name"]]]
    h = stable_step(robot)
    effects = ["inertia", "cables", {"motors": {"modes": modes}} if modes else "motors", "gravity"]
    scene = {"name": "drawn", "model": {"kind": "robot", "robot": robot}, "initial": {"drawn": True},
             "effects": effects, "duration": 30 * h, "integrator": {"max_step": h}}
    if inputs:
        scene["inputs"] = inputs
    model = compile_scene(load_scene(scene))
    p = model.plan
    y, _ = drawn_state(model, seed)
    samples: list = []
    model.record(model.state_from(y, t_end=30 * h), np.arange(31) * h, samples)
    o = model.observe(samples)
    n, cable = p.n_dof, p.motor_cable
    l0 = o["state"][:, 2 * n:2 * n + len(cable)]
    assert np.all((p.motor_lo <= l0) & (l0 <= p.motor_hi))
    k, t_max = p.cable_k[cable], p.cable_t_max[cable]
    tension = o["member_forces"][:, len(robot["rods"]) + cable]
    assert np.all(tension <= t_max)
    length = o["member_lengths"][:, len(robot["rods"]) + cable]
    moved = np.abs(np.diff(l0, axis=0))
    slewed = moved <= p.motor_speed * h * (1 + 1e-9) + 1e-15 * l0[1:]
    paid_out = (np.diff(l0, axis=0) > 0) & ((np.abs(k * (length[1:] - l0[1:]) - t_max) <= 1e-9 * t_max + 1e-12 * k * length[1:])
                                             | (l0[1:] == p.motor_hi))
    assert np.all(slewed | paid_out)
