"""Physical invariants of robots drawn by hypothesis over the description's accepted ranges,
not the shipped robots: one to three rods (any length, mass, cap share, radii), one to five
cables between any of their caps (any stiffness, damping, rest length, half of them motor
driven with any lag, slew and tension limits), free point masses (pinned on all, some or
no axes), a rigid triangle beside the rods (moving or fixed), point masses riding on caps
and body nodes, a floor of any orientation and contact and friction parameters, the scene's
overrides of the motors (lag, slew, tension limit, modes) and of the floor, gravity of any
direction and 0.1 to 30 m/s^2. Masses, stiffnesses, damping and the floor's contact
parameters are drawn log-uniformly over the whole range the description accepts (1e-15 to
1e15 of their unit, ``robot_schema.MIN_SIZE`` to ``MAX_MAGNITUDE``); lengths, radii, lags,
speeds and friction coefficients over the orders of magnitude the drawing's coordinates
leave them (lengths 1e-3 to 1e2 m, radii 1e-6 to 1 m), and states are drawn around the drawing (moved, turned, moving, caps in and
out of the floor, anchored sticking and slipping).

At every evaluated state, in both kernel families:

- cables never push and a slack cable (``l <= l0``, also ``l = 0``) exerts nothing; no
  tension exceeds its motor's limit;
- the floor never pulls (no normal force out of contact), friction never exceeds ``mu F_n``
  (``mu_s`` sticking, ``mu_k`` slipping) and the resisting couples ``b F_n``;
- Newton-Euler: the linear and angular momenta change by the weights, the pins' reactions
  and the floor's forces and couples alone (cables between moving parts are internal);
- frame invariance: the robot, its floor and gravity moved by a rigid motion give the moved
  forces (nodal, friction, couples) and the same tensions and contact forces.

Over time: with gravity, floor and motors off, a drawn robot's linear momentum is conserved
to rounding through a run (the cables' forces cancel at every stage, and RK4 keeps linear
invariants exactly, where each body's centre is its centre of mass). Through smooth runs
(no cable switching slack and taut, no cap touching or leaving the floor) the energy, the
angular momentum about the centre of mass and the linear momentum balance to RK4's order:
their residuals shrink at least 8-fold when the step is halved, with and without a
frictionless floor. A rod at rest on a floor of any orientation, gravity along the floor's
normal, reads ``g`` away from the floor on its IMU. Motors in any mode and command never
leave their range, slew faster than their limit (but when back-driven) or hold more than
their tension limit.

What users give beside the description: ``control.roll`` (any faces, heading, rate) is read
or refused in one line; the ``tensegrity gait`` command's flags give a checked gait or one
line.
"""

from __future__ import annotations

import math
import os
from unittest import mock

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tensegrity_core.general.rotation import exp_so3
from tensegrity_core.robot.contact import SPIN_TOLERANCE
from tensegrity_core.robot.description import RobotError
from tensegrity_core.robot.robot_schema import MIN_SIZE, robot_from_dict
from tensegrity_core.robot.rod import rod_inertia
from tensegrity_core.sim import compile_scene, load_scene
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.general.kernels.jit import KERNELS_VARIABLE, have_numba
from tensegrity_core.sim.general.robot.loops import NO_ANCHOR, SLIPPING, STICKING
from tensegrity_core.sim.general.robot.system import RobotSystem

KERNELS = ["numpy", "numba"] if have_numba() else ["numpy"]
ALL = ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"]


def _size(lo: float = 1e-15, hi: float = 1e15):
    """A positive size drawn log-uniformly in [lo, hi] (its unit's orders of magnitude alike;
    by default the whole range a robot's description accepts)."""
    return st.floats(np.log10(lo), np.log10(hi)).map(lambda e: float(10.0 ** e))


def _share(whole: float, share: float) -> float:
    """``whole * share``, or 0 where that is below the least size a robot takes (as a user
    would write it)."""
    part = whole * share
    return part if part >= MIN_SIZE else 0.0


def _maybe(size, zero: float = 0.0):
    return st.one_of(st.just(zero), size)


unit = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1).map(
    lambda v: np.array(v) / np.linalg.norm(v))


PIN_AXES = ("xyz", "x", "y", "z", "xy", "xz", "yz")


@st.composite
def robots(draw, floor: bool = True, pins: str = "any", damping: bool = True, riders: bool = True) -> dict:
    """A robot description (parsed data) drawn over the accepted ranges (module docstring).

    Beside the rods: up to two free point masses (each fully pinned, pinned along some axes
    or free; ``pins``: ``"any"``, ``"full"`` (fully pinned or free) or ``"none"``), perhaps a
    rigid triangle of three nodes (moving with its mass, or ``fixed`` where pins are drawn),
    point masses riding on rod caps and body nodes; every extra node joined to a rod's cap by
    a cable (``riders=False``: none riding, so every body's centre of mass is its reference
    point, the centroid of its nodes). ``damping=False``: every cable undamped."""
    n_rods = draw(st.integers(1, 3))
    nodes: dict[str, list[float]] = {}
    rods = []
    for i in range(n_rods):
        centre = np.array(draw(st.tuples(*[st.floats(-2.0, 2.0)] * 3))) + [5.0 * i, 0.0, 0.0]   # caps apart
        axis = draw(unit)
        length = draw(_size(1e-3, 1e2))
        mass = draw(_size(1e-13))                                 # its caps' 1 %, a size too
        radius = draw(_maybe(_size(1e-6, 1.0)))                   # 0: a slender rod, whose caps ...
        share = draw(st.floats(0.0 if radius > 0 else 0.01, 0.5))    # ... give it its axial inertia
        rod = {"name": f"r{i}", "nodes": [f"a{i}", f"b{i}"], "mass": mass, "radius": radius,
               "cap_mass": _share(mass, share), "cap_radius": draw(_size(1e-6, 1.0))}
        nodes[f"a{i}"] = (centre - axis * length / 2).tolist()
        nodes[f"b{i}"] = (centre + axis * length / 2).tolist()
        rods.append(rod)
    caps = list(nodes)
    out: dict = {"name": "drawn", "nodes": nodes, "rods": rods}
    masses: dict[str, float] = {}
    pinned: dict[str, str] = {}
    immobile: set[str] = set()                  # nodes that never move (fully pinned, on a fixed body)
    extra: list[str] = []                       # nodes a cable must join to the rods
    for i in range(draw(st.integers(0, 2))):
        name = f"p{i}"
        nodes[name] = (np.array(draw(st.tuples(*[st.floats(-2.0, 2.0)] * 3))) + [-5.0, 5.0 * i, 0.0]).tolist()
        axes = draw(st.sampled_from({"any": PIN_AXES + ("",), "full": ("xyz", ""), "none": ("",)}[pins]))
        if axes:
            pinned[name] = axes
        if axes == "xyz":
            immobile.add(name)
        if axes != "xyz" or draw(st.booleans()):   # a fully pinned node may carry a mass too
            masses[name] = draw(_size())
        extra.append(name)
    body = None
    if draw(st.booleans()):
        size = draw(_size(1e-3, 1e2))
        turn = Rotation.from_rotvec(draw(st.tuples(*[st.floats(-3.0, 3.0)] * 3))).as_matrix()
        centre = np.array(draw(st.tuples(*[st.floats(-2.0, 2.0)] * 3))) + [5.0 * n_rods, 0.0, 0.0]
        corners = size * np.array([[1.0, 0.0, 0.0], [-0.5, 0.75 ** 0.5, 0.0], [-0.5, -(0.75 ** 0.5), 0.0]])
        body = [f"t{j}" for j in range(3)]
        for name, corner in zip(body, corners):
            nodes[name] = (centre + turn @ corner).tolist()
        fixed = pins != "none" and draw(st.integers(0, 3)) == 0
        out["rigid_bodies"] = [{"name": "tri", "nodes": body, "mass": draw(_size()), "fixed": fixed}]
        if fixed:
            immobile.update(body)
        extra.append(body[0])
    for name in caps + (body or []) if riders else ():
        if draw(st.integers(0, 3)) == 0:
            masses[name] = draw(_size())
    names = list(nodes)

    def joinable(a: str, b: str) -> bool:
        return not ({a, b} <= immobile or (body is not None and {a, b} <= set(body)))
    pairs = [(a, b) for a in names for b in names if a < b and joinable(a, b)]
    ends = [(e, draw(st.sampled_from(caps))) for e in extra]
    ends += [draw(st.sampled_from(pairs)) for _ in range(draw(st.integers(1, 5)))]
    cables = []
    for j, (a, b) in enumerate(ends):
        cable = {"name": f"c{j}", "nodes": [a, b], "stiffness": draw(_size()),
                 "damping": draw(_maybe(_size())) if damping else 0.0,
                 "rest_length_ratio": draw(st.floats(0.2, 2.0))}
        if draw(st.booleans()):
            cable["motor"] = {"range": [1e-9, 1e4], "tau": draw(_maybe(_size(1e-4, 10.0))),
                              "max_speed": draw(st.one_of(st.just(".inf"), _size(1e-3, 1e2))),
                              "max_tension": draw(st.one_of(st.just(".inf"), _size()))}
        cables.append(cable)
    out.update(cables=cables, sensors={"imu": [r["name"] for r in rods] + (["tri"] if body else [])},
               gravity=(draw(st.floats(0.1, 30.0)) * draw(unit)).tolist())   # 0: the scene's standard
    if masses:
        out["masses"] = masses
    if pinned:
        out["pinned"] = pinned
    try:
        robot_from_dict(out)
    except RobotError as err:                   # refused: a rod too slender for double precision
        assume("axial inertia" not in err.reason)
        raise
    if floor:
        normal = draw(unit)
        lowest = min(float(np.dot(nodes[r["nodes"][k]], normal)) - r["cap_radius"] for r in rods for k in (0, 1))
        mu_s = draw(_maybe(_size(1e-3, 10.0)))
        out["floor"] = {"normal": normal.tolist(), "point": (lowest * normal).tolist(), "stiffness": draw(_size()),
                        "dissipation": draw(_maybe(_size())), "mu_static": mu_s,
                        "mu_kinetic": _share(mu_s, draw(st.floats(0.0, 1.0))), "tangential_stiffness": draw(_size()),
                        "tangential_damping": draw(_maybe(_size())),
                        "rolling_friction": draw(_maybe(_size(1e-6, 0.1))),
                        "torsional_friction": draw(_maybe(_size(1e-6, 0.1)))}
    return out


def _some(draw, options: dict) -> dict:
    """Some of ``options`` (key: strategy), each drawn."""
    return {k: draw(v) for k, v in options.items() if draw(st.booleans())}


@st.composite
def effects_of(draw, robot: dict) -> list:
    """The scene's effects for ``robot``: all of them, each robot effect with drawn overrides
    of the description's values (every motor's lag, slew and tension limit and perhaps
    mode; the floor's contact and friction parameters)."""
    motors = _some(draw, {"tau": _maybe(_size(1e-4, 10.0)), "max_speed": st.one_of(st.just(".inf"), _size(1e-3, 1e2)),
                   "max_tension": st.one_of(st.just(".inf"), _size())})
    motors = {k: (float("inf") if v == ".inf" else v) for k, v in motors.items()}
    actuated = [c["name"] for c in robot["cables"] if "motor" in c]
    if actuated and draw(st.booleans()):
        motors["modes"] = {c: draw(st.sampled_from(["rest_length", "reel_speed", "tension"])) for c in actuated}
    out: list = ["inertia", "cables", {"motors": motors}, "gravity"]
    if "floor" in robot:
        contact = _some(draw, {"stiffness": _size(), "dissipation": _maybe(_size())})
        mu_s = draw(_maybe(_size(1e-3, 10.0)))
        friction = _some(draw, {"tangential_stiffness": _size(), "tangential_damping": _maybe(_size()),
                         "rolling_friction": _maybe(_size(1e-6, 0.1)), "torsional_friction": _maybe(_size(1e-6, 0.1))})
        if draw(st.booleans()):
            friction.update(mu_static=mu_s, mu_kinetic=_share(mu_s, draw(st.floats(0.0, 1.0))))
        out += [{"contact": contact}, {"friction": friction}]
    return out + ["sensors"]


def model_of(robot: dict, effects=ALL, duration: float = 1.0, step: float | None = None):
    """The robot's model (``step``: default :func:`stable_step`, which the scene's check of
    the step accepts)."""
    return compile_scene(load_scene({"name": "drawn", "model": {"kind": "robot", "robot": robot},
                                     "initial": {"drawn": True}, "effects": effects, "duration": duration,
                                     "integrator": {"max_step": step or stable_step(robot, effects)}}))


def _override(effects, effect: str, key: str, value: float) -> float:
    """The value of ``key`` of a robot effect: the scene's override, else the description's."""
    for e in effects:
        if isinstance(e, dict) and effect in e and key in e[effect]:
            return float(e[effect][key])
    return value


def stable_step(robot: dict, effects=ALL) -> float:
    """A fixed step [s] that RK4 resolves for the cables and the floor of ``robot`` in the
    states :func:`drawn_state` draws and the runs from them.

    - A cable of stiffness ``k`` and damping ``c`` between nodes of inverse masses ``1/m_a'``,
      ``1/m_b'`` moves them as a spring on the mass ``1 / (1/m_a' + 1/m_b')``: at a rod's end
      ``1/m' <= 4/m`` (a rod's transverse inertia ``I_t`` is at least ``m L^2 / 12``, so
      ``1/m + (L/2)^2 / I_t <= 4/m``); at a node of the triangle (three equal shares of its
      mass ``M`` at distance ``r`` from its centre: ``1/M + r^2 / (M r^2 / 2) = 3/M``) at most
      ``4/M``; at a free point mass ``1/m``; at a node that does not move 0. Point masses
      riding on a rod or the triangle only lower these (more mass, more inertia).
    - Its tension ``T`` turns the rod about its centre as the rod turns (a pull at the cap,
      ``L/2`` from the centre: the rod aligning with the cable, a pendulum of ``T L / 2`` on
      ``I_t``, so ``omega^2 <= 6 T / (m L)``; the triangle likewise, ``T r`` on ``M r^2 / 2``);
      ``T`` is bounded by the cable stretched to its drawn length plus the drawn state's moves
      (half the drawing's size) and both ends' bodies' sizes, and its damper at 10 m/s.
    - Each cap on the floor adds its normal spring and its friction anchor (the scene's
      overrides where given).
    Summed (Gershgorin) this bounds the fastest rates ``omega^2`` and ``sigma``; half the
    inverse of the larger keeps ``h omega``, ``h sigma`` well inside RK4's region (2.8 along
    either axis)."""
    nodes = {name: np.asarray(x, dtype=float) for name, x in robot["nodes"].items()}
    size = float(np.ptp(np.array(list(nodes.values())), axis=0).max()) + 1e-3
    inverse = {name: 1.0 / robot.get("masses", {}).get(name, np.inf) for name in nodes}
    pendulum = {name: 0.0 for name in nodes}             # 6 / (m L) [1/(kg m)] of the body a node is on
    reach = {name: 0.0 for name in nodes}                # its body's size [m]
    for name, axes in robot.get("pinned", {}).items():
        if axes == "xyz":
            inverse[name] = 0.0
    for r in robot["rods"]:
        a, b = r["nodes"]
        length = float(np.linalg.norm(nodes[b] - nodes[a]))
        for end in (a, b):
            inverse[end], pendulum[end], reach[end] = 4.0 / r["mass"], 6.0 / (r["mass"] * length), length
    for body in robot.get("rigid_bodies", []):
        r = float(np.linalg.norm(nodes[body["nodes"][0]] - np.mean([nodes[v] for v in body["nodes"]], axis=0)))
        for v in body["nodes"]:
            inverse[v], pendulum[v], reach[v] = (0.0, 0.0, 0.0) if body["fixed"] else \
                (4.0 / body["mass"], 6.0 / (body["mass"] * r), 2.0 * r)
    omega2 = sigma = 0.0
    for c in robot["cables"]:
        a, b = c["nodes"]
        inv = inverse[a] + inverse[b]
        omega2 += c["stiffness"] * inv
        sigma += c["damping"] * inv
        stretched = float(np.linalg.norm(nodes[b] - nodes[a])) + 0.5 * size + reach[a] + reach[b]
        tension = c["stiffness"] * stretched + c["damping"] * 10.0
        omega2 += tension * (pendulum[a] + pendulum[b])
    floor = robot.get("floor", {})
    k = _override(effects, "contact", "stiffness", floor.get("stiffness", 0.0))
    k_t = _override(effects, "friction", "tangential_stiffness", floor.get("tangential_stiffness", k))
    c_t = _override(effects, "friction", "tangential_damping", floor.get("tangential_damping", 0.0))
    for r in robot["rods"]:                 # each cap on the floor: its normal spring, its friction anchor
        # the anchor acts at the contact point, ``cap_radius`` off the axis: it spins the rod
        # about its axis too (docs/robots.md), ``r^2 / I_a`` more inverse mass
        a, b = r["nodes"]
        cap_mass = r.get("cap_mass", 0.0)
        _, I_a = rod_inertia(r["mass"] - 2 * cap_mass, r["radius"], cap_mass, r.get("cap_radius", r["radius"]),
                             float(np.linalg.norm(nodes[b] - nodes[a])))
        spin = r.get("cap_radius", r["radius"]) ** 2 / float(I_a)
        omega2 += 2.0 * (k * 4.0 / r["mass"] + k_t * (4.0 / r["mass"] + spin))
        sigma += 2.0 * c_t * (4.0 / r["mass"] + spin)
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


@st.composite
def scenes(draw, **robot_options) -> tuple[dict, list]:
    """A drawn robot (:func:`robots`) and its scene's effects with drawn overrides."""
    robot = draw(robots(**robot_options))
    return robot, draw(effects_of(robot))


def balances(model, y: np.ndarray, ev) -> tuple[np.ndarray, np.ndarray, float, float]:
    """``(dP/dt - F, dL/dt - M, force scale [N], moment scale [N m])``: Newton-Euler of the
    whole robot written out, momenta about the origin, at the evaluated state ``y``.

    Each moving body (centre ``c``, rate ``v``, angular velocity ``w`` in the world, mass
    ``m``, first moment ``S = R s`` about ``c`` and inertia ``I_c = R I R^T`` about ``c``) has
    ``P = m v + w x S`` and ``L = m c x v + c x (w x S) + S x v + I_c w``, so
    ``dP/dt = m a + w' x S + w x (w x S)`` and
    ``dL/dt = m c x a + c x (w' x S + w x (w x S)) + S x a + I_c w' + w x I_c w``; a free
    point mass has ``m x x a``. The external forces on what moves: the weights, the cables'
    pulls ``T u`` on moving nodes (those between two moving nodes cancel, and their moments,
    being along the line between them) and the pins' reactions (on a node pinned along some
    axes they cancel that node's load along those axes), and the floor's normal force at
    each cap's centre, friction at its contact point ``x - r n`` and the resisting couples.

    The scales sum the terms' sizes, for rounding; a body's ``w'`` solved with an inertia of
    condition number ``kappa`` (a slender rod with tiny caps: ``I_a / I_t`` down to 1e-12) is
    rounded to ``kappa eps`` of it, so its inertia's terms count ``1 + 1e-6 kappa`` times
    (1e-9 of the scale: ``1e-15 kappa``)."""
    p = model.plan
    n = p.n_dof
    X = ev.positions[0]
    nodal = np.zeros_like(X)                            # the cables' pulls [N]
    u = X[p.cable_b] - X[p.cable_a]
    length = np.linalg.norm(u, axis=1)
    pull = ev.tensions[0][:, None] * np.divide(u, length[:, None], out=np.zeros_like(u), where=length[:, None] > 0)
    np.add.at(nodal, p.cable_a, pull)
    np.add.at(nodal, p.cable_b, -pull)
    moving = np.zeros(X.shape, dtype=bool)
    moving[p.on_node] = True
    moving[p.free_node, p.free_axis] = True
    load = np.where(moving, p.external + nodal, 0.0)
    load_size = np.where(moving, np.abs(p.external) + np.abs(nodal), 0.0).sum(axis=1)
    F, M = load.sum(axis=0), np.cross(X, load).sum(axis=0)
    f_scale = float(load_size.sum())
    m_scale = float(np.linalg.norm(X, axis=1) @ load_size)
    nvec = p.floor_normal
    for k, node in enumerate(p.cap_node):
        fn, ff, at = ev.normal[0, k] * nvec, ev.friction[0, k], X[node] - p.cap_radius[k] * nvec
        F += fn + ff
        M += np.cross(X[node], fn) + np.cross(at, ff) + ev.couple[0, k]
        f_scale += ev.normal[0, k] + np.linalg.norm(ff)
        m_scale += (np.linalg.norm(X[node]) + p.cap_radius[k]) * (ev.normal[0, k] + np.linalg.norm(ff)) + \
            np.linalg.norm(ev.couple[0, k])
    dP, dL = np.zeros(3), np.zeros(3)
    rates = ev.derivative[0, n:2 * n]
    for b, d in enumerate(p.body_dof):
        c, w = y[d:d + 3], y[n + d + 3:n + d + 6]
        a, dw = rates[d:d + 3], rates[d + 3:d + 6]
        R = ev.rotations[0, b]
        S, I_c = R @ p.body_first_moment[b], R @ p.body_inertia[b] @ R.T
        m = p.body_mass[b]
        turning = np.cross(dw, S) + np.cross(w, np.cross(w, S))
        dP += m * a + turning
        dL += m * np.cross(c, a) + np.cross(c, turning) + np.cross(S, a) + I_c @ dw + np.cross(w, I_c @ w)
        f_scale += m * np.linalg.norm(a) + np.linalg.norm(turning)
        m_scale += np.linalg.norm(c) * (m * np.linalg.norm(a) + np.linalg.norm(turning)) + \
            np.linalg.norm(S) * np.linalg.norm(a) + \
            np.linalg.norm(I_c, 2) * (np.linalg.norm(dw) + np.linalg.norm(w) ** 2) * (1.0 + 1e-6 * np.linalg.cond(I_c))
    a_free = np.zeros(X.shape)
    a_free[p.free_node, p.free_axis] = rates[:len(p.free_node)] / p.free_inv_mass
    dP += a_free.sum(axis=0)
    dL += np.cross(X, a_free).sum(axis=0)
    f_scale += float(np.abs(a_free).sum())
    m_scale += float(np.linalg.norm(X, axis=1) @ np.abs(a_free).sum(axis=1))
    return dP - F, dL - M, f_scale, m_scale


@settings(max_examples=60)
@given(scene=scenes(), seed=st.integers(0, 2**32 - 1), kernels=st.sampled_from(KERNELS))
def test_forces_obey_their_laws_and_the_momenta_change_by_the_external_ones_alone(scene, seed, kernels):
    """Cables, floor and friction within their laws; Newton-Euler of the whole robot
    (:func:`balances`): its linear and angular momenta about the origin change by the weights,
    the pins' reactions, the cables to what does not move and the floor's forces and couples
    alone (the cables between moving parts are internal)."""
    robot, effects = scene
    model = model_of(robot, effects)
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
    force, moment, f_scale, m_scale = balances(model, y, ev)
    assert np.abs(force).max() <= 1e-9 * f_scale
    assert np.abs(moment).max() <= 1e-9 * m_scale


def _moved(robot: dict, Q: np.ndarray, t: np.ndarray) -> dict:
    """``robot`` moved by the rigid motion ``x -> Q x + t``, its floor and gravity with it."""
    out = dict(robot, nodes={k: (Q @ v + t).tolist() for k, v in robot["nodes"].items()},
               gravity=(Q @ robot["gravity"]).tolist())
    if "floor" in robot:
        out["floor"] = dict(robot["floor"], normal=(Q @ robot["floor"]["normal"]).tolist(),
                            point=(Q @ robot["floor"]["point"] + t).tolist())
    return out


@settings(max_examples=40)
@given(scene=scenes(pins="full"), seed=st.integers(0, 2**32 - 1), turn=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
       shift=st.tuples(*[st.floats(-10.0, 10.0)] * 3), kernels=st.sampled_from(KERNELS))
def test_a_rigidly_moved_robot_gives_the_moved_forces(scene, seed, turn, shift, kernels):
    """State ``y`` of the robot and the state of the moved robot that is ``y`` moved: centres
    ``Q c + t``, charts ``Q R_ref Q^T`` and rotation vectors ``Q theta`` (its bodies' drawn
    frames are turned by ``Q``), velocities, angular velocities and anchor offsets ``Q`` of
    the original's. Its node positions are the moved ones; its nodal forces (weights, cables,
    floor), friction forces and resisting couples ``Q`` of the original's; tensions, lengths,
    depths and normal forces the same. Free point masses move as the centres; pins are
    drawn on all three axes or none (a pin along one world axis is not turned with the robot)."""
    robot, effects = scene
    Q, t = Rotation.from_rotvec(turn).as_matrix(), np.array(shift)
    model, moved = model_of(robot, effects), model_of(_moved(robot, Q, t), effects)
    p = model.plan
    y, R_ref = drawn_state(model, seed)
    n, na, ncap = p.n_dof, len(p.motor_cable), len(p.cap_node)
    blocks = np.concatenate([np.arange(2 * n), 2 * n + na + np.arange(3 * ncap)]).reshape(-1, 3)
    turned = y.copy()
    turned[blocks] = y[blocks] @ Q.T
    turned[p.body_dof[:, None] + np.arange(3)] += t
    turned[:len(p.free_node)] += t[p.free_axis]
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


def momenta(model, samples) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per sample ``(P [kg m/s], L about the centre of mass [kg m^2/s], scale of P's terms,
    scale of L's terms, the centre of mass [m])`` of the moving bodies and free point masses
    (:func:`balances`' ``P`` and ``L``; the centre of mass ``(sum m c + S + sum m x) / sum m``)."""
    p, n = model.plan, model.plan.n_dof
    P, L, P_size, L_size, first = [], [], [], [], []
    for _, y, system in samples:
        ev = system.evaluate(y[None])
        X, V = ev.positions[0], ev.velocities[0]
        p_sum, l_sum, mass_moment = np.zeros(3), np.zeros(3), np.zeros(3)
        p_size = l_size = 0.0
        for b, d in enumerate(p.body_dof):
            c, v, w = y[d:d + 3], y[n + d:n + d + 3], y[n + d + 3:n + d + 6]
            R = ev.rotations[0, b]
            S, I_c, m = R @ p.body_first_moment[b], R @ p.body_inertia[b] @ R.T, p.body_mass[b]
            terms = (m * v, np.cross(w, S))
            p_sum += sum(terms)
            l_terms = (m * np.cross(c, v), np.cross(c, np.cross(w, S)), np.cross(S, v), I_c @ w)
            l_sum += sum(l_terms)
            p_size += sum(np.linalg.norm(x) for x in terms)
            l_size += sum(np.linalg.norm(x) for x in l_terms[:3]) + np.linalg.norm(I_c, 2) * np.linalg.norm(w)
            mass_moment += m * c + S
        m_free = np.zeros(X.shape)
        m_free[p.free_node, p.free_axis] = 1.0 / p.free_inv_mass
        p_sum += (m_free * V).sum(axis=0)
        l_sum += np.cross(X, m_free * V).sum(axis=0)
        p_size += float(np.abs(m_free * V).sum())
        l_size += float(np.linalg.norm(X, axis=1) @ np.abs(m_free * V).sum(axis=1))
        mass_moment += (m_free * X).sum(axis=0)
        P.append(p_sum), L.append(l_sum), P_size.append(p_size), L_size.append(l_size), first.append(mass_moment)
    total = float(p.body_mass.sum() + (1.0 / p.free_inv_mass[::3]).sum() if len(p.free_node) else p.body_mass.sum())
    centre = np.array(first) / total
    P = np.array(P)
    L_cm = np.array(L) - np.cross(centre, P)
    return P, L_cm, np.array(P_size), np.array(L_size) + np.linalg.norm(centre, axis=1) * np.array(P_size), centre


@settings(max_examples=15)
@given(robot=robots(floor=False, pins="none", riders=False), seed=st.integers(0, 2**32 - 1))
def test_without_gravity_floor_and_motors_a_drawn_robot_keeps_its_linear_momentum(robot, seed):
    """Cables only (motors held, damping as drawn): 20 fixed steps (:func:`stable_step`) from a
    drawn state whose cables may go slack and taut; ``P`` (:func:`momenta`) stays what it was
    to rounding of its terms. Exactly: each body's centre is its centre of mass, so ``P`` is
    linear in the state and RK4 keeps it (a point mass riding off the centre adds ``w x S``,
    which RK4 keeps to its order only: the smooth runs below)."""
    h = stable_step(robot)
    model = model_of(robot, ["inertia", "cables"], duration=20 * h, step=h)
    y, _ = drawn_state(model, seed)
    samples: list = []
    model.record(model.state_from(y, t_end=20 * h), np.arange(0, 21) * h, samples)
    P, _, size, _, _ = momenta(model, samples)
    assert np.all(np.isfinite(P))
    assert np.abs(P - P[0]).max() <= 1e-12 * size.max() * len(P)


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
        try:
            model = model_of(robot)
        except SceneError as err:              # refused: a rod too slender for double precision
            assume("axial inertia" not in err.reason)
            raise
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


@settings(max_examples=40)
@given(faces=st.integers(-3, 10**6), heading=st.tuples(*[st.floats(-1e3, 1e3)] * 2),
       rate=st.floats(-300.0, 15.0).map(lambda e: float(10.0 ** e)), step=_size(1e-6, 0.1))
def test_a_closed_loop_roll_is_accepted_or_refused_in_one_line(faces, heading, rate, step):
    """``control.roll`` over everything its keys take (any count of faces, heading, rate from
    1e-300 to 1e15 Hz, any fixed step): the scene is read, or refused in one line naming the
    key; a rate above the step rate ``1 / max_step`` is refused (the commands act once a
    step: faster samples see the same state, each at the cost of an evaluation)."""
    scene = {"name": "roll", "model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
             "control": {"roll": {"faces": faces, "heading": list(heading), "rate": rate}},
             "effects": ["inertia", "cables", "gravity"], "duration": 1.0, "integrator": {"max_step": step}}
    try:
        spec = load_scene(scene)
    except SceneError as err:
        assert "\n" not in str(err)
        key = ".".join(map(str, err.key))
        assert key in ("control.roll.faces", "control.roll.heading", "control.roll.rate", "integrator.max_step")
        assert (key == "control.roll.faces") == (faces < 1)
        if faces >= 1 and math.hypot(*heading) > 0 and key != "integrator.max_step":
            assert key == "control.roll.rate" and rate * step > 1.0
        return
    assert faces >= 1 and math.hypot(*heading) > 0 and rate * spec.integrator.max_step <= 1.0 + 1e-12


@settings(max_examples=40)
@given(gait=st.sampled_from(["roll", "six_bar_roll", "three_bar_crawl", "spine_bend", "walk"]),
       robot=st.sampled_from(["six_bar", "three_bar", "spine", "five_bar"]),
       faces=st.one_of(st.none(), st.integers(-3, 10**9)), repeats=st.one_of(st.none(), st.integers(-3, 10**9)),
       heading=st.one_of(st.none(), st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=2, max_size=2)),
       max_time=st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True)))
def test_the_gait_commands_flags_give_a_gait_or_one_line(gait, robot, faces, repeats, heading, max_time):
    """``tensegrity gait ROBOT GAIT`` with any flags its parser takes (``--faces``,
    ``--repeats``, ``--heading X Y``, ``--max-time``, numbers of any size, NaN and infinities):
    the checked gait (or closed-loop roll: 1 <= faces <= 8640, a finite nonzero heading, a
    time limit in (0, 86400] s), or a ``CliError`` of one line (exit 2 or its own code)."""
    from tensegrity_ros.cli._common import CliError
    from tensegrity_ros.cli.cmd_gait import ROLL, build_gait, check_roll

    try:
        if gait == ROLL:
            n, h, limit = check_roll(robot, faces, heading, max_time, repeats)
            assert 1 <= n <= 8640 and all(map(math.isfinite, h)) and math.hypot(*h) > 0   # 8640: a day at 10 s
            assert 0 < limit <= 86400.0                                                   # a day of simulation
        else:
            _, table = build_gait(robot, gait, faces, repeats)
            assert np.all(np.isfinite(table.times)) and np.all(np.isfinite(table.rest_lengths))
    except CliError as err:
        assert str(err) and "\n" not in str(err)


def energy(model, samples) -> tuple[np.ndarray, np.ndarray]:
    """Per sample ``(E [J], scale of its terms [J])``: kinetic ``1/2 m v^2 + v . (w x S) +
    1/2 w . I_c w`` of each body (:func:`balances`' notation) and ``1/2 m v^2`` of each free
    point mass, the cables' strain ``1/2 k (l - l0)^2`` while taut, and gravity's
    ``-sum m g . x`` over the nodes' lumped masses (a rod's half at each cap, a body's shares,
    the point masses: their centre of mass is the robot's); with a floor of no dissipation
    the caps' springs ``1/2 k delta^2`` while pressed in."""
    p, n = model.plan, model.plan.n_dof
    E, size = [], []
    for _, y, system in samples:
        ev = system.evaluate(y[None])
        X, V = ev.positions[0], ev.velocities[0]
        terms = []
        for b, d in enumerate(p.body_dof):
            v, w = y[n + d:n + d + 3], y[n + d + 3:n + d + 6]
            R = ev.rotations[0, b]
            S, I_c, m = R @ p.body_first_moment[b], R @ p.body_inertia[b] @ R.T, p.body_mass[b]
            terms += [0.5 * m * v @ v, v @ np.cross(w, S), 0.5 * w @ I_c @ w]
        terms += list(0.5 * V[p.free_node, p.free_axis] ** 2 / p.free_inv_mass)
        stretch = np.maximum(ev.lengths[0] - ev.rest_lengths[0], 0.0)
        terms += list(0.5 * p.cable_k * stretch ** 2)
        terms += list(-np.einsum("ij,ij->i", p.external, X))             # external: the weights m g
        terms += list(0.5 * p.floor_params[0] * np.maximum(ev.depth[0], 0.0) ** 2)
        E.append(sum(terms))
        size.append(sum(abs(t) for t in terms))
    return np.array(E), np.array(size)


def _jacobian_rates(model, y: np.ndarray) -> np.ndarray:
    """The rates' Jacobian ``d(v, a)/d(x, v)`` at ``y`` by central differences (one batch)."""
    n = model.plan.n_dof
    scale = np.maximum(np.abs(y[:2 * n]), 1e-3) * 1e-6
    Y = np.repeat(y[None], 4 * n, axis=0)
    idx = np.arange(2 * n)
    Y[idx, idx] += scale
    Y[2 * n + idx, idx] -= scale
    f = model.system.evaluate(Y).derivative[:, :2 * n]
    return ((f[:2 * n] - f[2 * n:]) / (2.0 * scale[:, None])).T


def floor_rates(model, samples, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample the floor's force [N] on the robot, its moment about the centre of mass
    ``centre`` [N m] (normal forces along ``n`` at the caps' centres) and the scale of their
    terms."""
    p = model.plan
    F, M, size = [], [], []
    for (_, y, system), c in zip(samples, centre):
        ev = system.evaluate(y[None])
        f = ev.normal[0][:, None] * p.floor_normal
        arm = ev.positions[0][p.cap_node] - c
        F.append(f.sum(axis=0)), M.append(np.cross(arm, f).sum(axis=0))
        size.append(float(ev.normal[0] @ (1.0 + np.linalg.norm(arm, axis=1))))
    return np.array(F), np.array(M), np.array(size)


def _simpson(f: np.ndarray, h: float) -> np.ndarray:
    """``int_0^t f`` at every second sample (Simpson's rule on samples ``h`` [s] apart)."""
    parts = (f[:-2:2] + 4.0 * f[1:-1:2] + f[2::2]) * h / 3.0
    return np.concatenate([np.zeros((1,) + f.shape[1:]), np.cumsum(parts, axis=0)])


@pytest.mark.parametrize("floor", [False, True], ids=["no floor", "on the floor"])
@settings(max_examples=20)
@given(data=st.data(), seed=st.integers(0, 2**32 - 1))
def test_a_smooth_run_keeps_energy_and_momenta_to_the_order_of_rk4(floor, data, seed):
    """Undamped cables, motors held, gravity and, without a floor, no external force: the
    energy ``E`` (:func:`energy`), the angular momentum about the centre of mass ``L``
    (uniform gravity has no moment about it) and ``P - M g t`` (:func:`momenta`) are
    invariants. On a floor without friction and dissipation, pressed in on its lowest caps:
    ``E`` with the caps' springs is, and ``L`` and ``P - M g t`` change by the floor's
    moment about the centre of mass and its force (:func:`floor_rates`, integrated by
    Simpson's rule over the samples, ``O(h^4)`` as well).

    RK4's global error over a fixed horizon is ``O(h^4)``, so these balances' residuals
    over the same horizon shrink at least 8-fold (16 asymptotically; 32 for a harmonic
    mode's energy, ``|R(iz)|^2 = 1 - z^6/72 + ...``) when the step is halved, up to
    rounding; an energy or moment source (a force that is not a gradient, a couple about the
    centre of mass, a floor force at the wrong point) leaves a residual alike at both steps
    and fails this, as does an error of lower order.

    The horizon is ``1 / omega`` of the fastest mode at the start (the rates' Jacobian; at
    most 4 :func:`stable_step`, for the caps not yet on the floor), in 4 steps
    (``h omega = 1/4``) against 8, from the drawing with rates small beside the cables'
    stretch and the caps' depth, so no cable switches between slack and taut and no cap
    touches or leaves the floor (checked at every sample; the derivative jumps there and the
    order drops). Rounding: 1e-13 of the balances' terms a step, ``1 + 1e-6 kappa`` times for
    bodies whose inertia has the condition number ``kappa`` (:func:`balances`)."""
    robot = data.draw(robots(floor=floor, pins="none", damping=False))
    effects = ["inertia", "cables", "gravity"] + ([{"contact": {"dissipation": 0.0}}] if floor else [])
    model = model_of(robot, effects)
    p, n = model.plan, model.plan.n_dof
    rng = np.random.default_rng(seed)
    y = model.y0.copy()
    ev = model.system.evaluate(y[None])
    margin = float(np.abs(ev.lengths[0] - ev.rest_lengths[0]).min())
    if floor:                                          # pressed in by up to its caps' radius
        sink = float(p.cap_radius.min()) * data.draw(st.floats(0.01, 1.0))
        y[p.body_dof[:, None] + np.arange(3)] -= sink * p.floor_normal
        y[:len(p.free_node)] -= sink * p.floor_normal[p.free_axis]
        margin = min(margin, sink)
    omega = float(np.abs(np.linalg.eigvals(_jacobian_rates(model, y))).max())
    horizon = min(1.0 / omega if omega > 0 else np.inf, 4.0 * stable_step(robot, effects))  # the check's bound too
    nodes = np.array(list(robot["nodes"].values()))
    size = float(np.ptp(nodes, axis=0).max()) + 1e-3
    y[n:2 * n] = rng.normal(0.0, 1.0, n) * 0.05 * margin / horizon / max(1.0, size)
    kappa = max((np.linalg.cond(I) for I in p.body_inertia), default=1.0)
    residuals = []
    for steps in (4, 8):
        h = horizon / steps
        m = model_of(robot, effects, duration=horizon, step=h)
        samples: list = []
        m.record(m.state_from(y, t_end=horizon), np.linspace(0.0, horizon, steps + 1), samples)
        evs = [s[2].evaluate(s[1][None]) for s in samples]
        pattern = np.array([np.concatenate([e.tensions[0] > 0.0, e.normal[0] > 0.0]) for e in evs])
        assume(np.all(pattern == pattern[0]))
        E, E_size = energy(m, samples)
        P, L, P_size, L_size, centre = momenta(m, samples)
        t = np.array([s[0] for s in samples])
        P = P - np.outer(t, p.external.sum(axis=0))                    # M g t
        if floor:
            F, M, FM_size = floor_rates(m, samples, centre)
            P[::2] -= _simpson(F, h)
            L[::2] -= _simpson(M, h)
            P_size, L_size = P_size + FM_size * horizon, L_size + FM_size * horizon
        keep = slice(None, None, steps // 2)                            # the common instants 0, T/2, T
        residuals.append([(np.abs(q[keep] - q[0]).max(), s.max() * 1e-13 * steps * (1.0 + 1e-6 * kappa))
                          for q, s in ((E, E_size), (L, L_size), (P, P_size))])
    for (coarse, _), (fine, rounding), what in zip(*residuals, ("energy", "angular momentum", "linear momentum")):
        assert fine <= coarse / 8.0 + rounding, (what, coarse, fine, rounding)
