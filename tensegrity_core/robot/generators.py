"""The shipped robots as descriptions (plain data), with every parameter's source.

Each function returns the description dict of one robot (``robot_from_dict`` builds it,
``dump_description`` writes it to ``examples/NAME.yaml``; the shipped files are these
functions' output, tested). Values from a public model or paper say so; values chosen here
say why (docs/design/robots.md, "Parameters", tabulates them all).

- :func:`three_bar`: the Rutgers/Yale 3-bar (TT-3), from its public MuJoCo model
  ``3prism_jonathan_steady_side.xml`` (github.com/drsteinkauz/tensegrity-denoising-RL,
  commit 0d93d53; header "Copyright Kun Wang"), drawn as a regular twisted prism.
- :func:`six_bar`: a SUPERball-like icosahedron (expanded octahedron), from the SUPERball
  example of Rible.jl (github.com/Rible-Sim/Rible.jl, ``examples/robots/superball.jl``),
  all 24 cables actuated.
- :func:`spine`: the C-shaped tensegrity spine of the shipped ``spine_release`` scene
  (``tensegrity_spine(10, shape="C", EA=500)``, 0.05 kg vertebrae) with its side cords
  motor-driven.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.general.formfind import form_find
from tensegrity_core.general.generators import tensegrity_spine
from tensegrity_core.robot.robot_schema import robot_from_dict
from tensegrity_core.robot.statics import rest_shape

FloatArray = NDArray[np.float64]

# --------------------------------------------------------------------------- three_bar
#: TT-3 rod: cap centres at +-0.688 m (geom ``r01`` size "0.0381 0.688"; sites ``s0``, ``s1``).
TT3_ROD_LENGTH = 2 * 0.688
#: Capsule radius of the rod's tube [m] (geom ``r01``: a cylinder of radius 0.0381).
TT3_ROD_RADIUS = 0.0381
#: End-cap spheres [m] (geoms ``s0``..``s5``: size 0.0675).
TT3_CAP_RADIUS = 0.0675
#: Rod mass [kg]: tube 1.0 + caps 2 x 0.5 + motor housings 2 x 1.0 (geoms r01, s0, s1, b0, b1).
TT3_ROD_MASS = 4.0
#: The motor filter's time constant [s] (``dyntype="filter" dynprm="1 0 0"``).
TT3_MOTOR_TAU = 1.0
#: Actuated cables: the affine actuator ``F = 6667 a + 3290 - 6666 L - 133 Ldot`` clamped to
#: ``forcerange="-267 0"`` is a cable of stiffness 6666 N/m, damping 133 N s/m and rest length
#: ``3290/6666 + (6667/6666) a`` = 0.4936 m + a for the control ``a`` in ``ctrlrange="-0.45 0.15"``.
TT3_ACTIVE_STIFFNESS, TT3_ACTIVE_DAMPING = 6666.0, 133.0
TT3_REST_OFFSET = 3290.0 / 6666.0
TT3_CONTROL_RANGE = (-0.45, 0.15)
TT3_MAX_TENSION = 267.0
#: Passive cables ``td_6..8``: springlength 0.8 m, stiffness 700 N/m, damping 100 N s/m.
TT3_PASSIVE = (0.8, 700.0, 100.0)
#: Floor friction (geom default ``friction="1 0.005 0.0001"``: one sliding coefficient, used
#: here as both static and kinetic).
TT3_FRICTION = 1.0


def _rod_inertia_tt3() -> list[float]:
    """``[I_t, I_a]`` [kg m^2] of a TT-3 rod from its MuJoCo geoms: the tube (cylinder 1 kg,
    r 0.0381, from -0.688 to 0.688), the caps (spheres 0.5 kg, r 0.0675, at +-0.688) and the
    motor housings (cylinders 1 kg, r 0.035, from +-0.238 to +-0.688)."""
    half = 0.688

    def cylinder(m: float, r: float, z0: float, z1: float) -> tuple[float, float]:
        length, centre = abs(z1 - z0), 0.5 * (z0 + z1)
        return m * (length * length / 12 + r * r / 4) + m * centre * centre, m * r * r / 2

    parts = [cylinder(1.0, 0.0381, -half, half), cylinder(1.0, 0.035, 0.238, half),
             cylinder(1.0, 0.035, -0.238, -half)]
    sphere_own = 0.4 * TT3_CAP_RADIUS**2
    parts += [(0.5 * (sphere_own + half * half), 0.5 * sphere_own)] * 2
    return [sum(p[0] for p in parts), sum(p[1] for p in parts)]


def three_bar() -> dict[str, Any]:
    """The Rutgers/Yale 3-bar: 3 rods, 6 motor-driven cables (two triangles of end caps), 3
    passive cables, 9 cable-length sensors, 2 IMUs (on rods r01 and r23), a floor.

    Drawn at its weightless rest shape, form-found from a regular prism (triangle cables
    0.5 m, twist 150 deg) lying on its side and turned back onto it, its lowest cap on the
    floor: every cable starts at the tension of the statics (actuated 74.9 N, within the
    motors' 267 N). Node and cable names follow the
    MuJoCo model (``s0``..``s5``, ``td_0``..``td_8``)."""
    L, side, twist = TT3_ROD_LENGTH, 0.5, math.radians(150.0)
    rho = side / math.sqrt(3.0)
    h = math.sqrt(L * L - 2 * rho * rho * (1 - math.cos(twist)))
    ang = np.radians([90.0, 210.0, 330.0])
    tri_a = np.c_[rho * np.cos(ang), rho * np.sin(ang), np.zeros(3)]
    tri_b = np.c_[rho * np.cos(ang + twist), rho * np.sin(ang + twist), np.full(3, h)]
    prism = np.array([tri_a[0], tri_b[0], tri_a[1], tri_b[1], tri_a[2], tri_b[2]])
    # lay it on its side: the prism's axis (z) along world x, then lift onto the floor
    turn = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    nodes = prism @ turn.T
    nodes[:, 2] += TT3_CAP_RADIUS - nodes[:, 2].min()
    names = [f"s{i}" for i in range(6)]
    lo, hi = (TT3_REST_OFFSET + TT3_CONTROL_RANGE[0], TT3_REST_OFFSET + TT3_CONTROL_RANGE[1])
    active = [("td_0", "s0", "s4"), ("td_1", "s0", "s2"), ("td_2", "s2", "s4"),
              ("td_3", "s1", "s5"), ("td_4", "s1", "s3"), ("td_5", "s3", "s5")]
    passive = [("td_6", "s1", "s4"), ("td_7", "s0", "s3"), ("td_8", "s2", "s5")]
    inertia = _rod_inertia_tt3()
    rods = [{"name": f"r{a}{b}", "nodes": [f"s{a}", f"s{b}"], "mass": TT3_ROD_MASS, "radius": TT3_ROD_RADIUS,
             "cap_radius": TT3_CAP_RADIUS, "inertia": inertia} for a, b in ((0, 1), (2, 3), (4, 5))]
    cables = [{"name": n, "nodes": [a, b], "rest_length": TT3_REST_OFFSET, "motor": True} for n, a, b in active]
    l0, k, c = TT3_PASSIVE
    cables += [{"name": n, "nodes": [a, b], "stiffness": k, "damping": c, "rest_length": l0} for n, a, b in passive]
    robot = {
        "name": "three_bar",
        "description": "Rutgers/Yale 3-bar tensegrity robot (TT-3), after its public MuJoCo model",
        "units": "SI",
        "nodes": {n: xyz for n, xyz in zip(names, nodes.tolist())},
        "rods": rods,
        "cable_defaults": {"stiffness": TT3_ACTIVE_STIFFNESS, "damping": TT3_ACTIVE_DAMPING,
                           "motor": {"range": [lo, hi], "tau": TT3_MOTOR_TAU, "max_tension": TT3_MAX_TENSION}},
        "cables": cables,
        "sensors": {"cable_length": "all", "cable_tension": "none", "imu": ["r01", "r23"]},
        # contact stiffness chosen for < 1 mm at rest (docs/robots.md); friction from the model
        "floor": {"stiffness": 2.0e5, "dissipation": 5.0, "mu_static": TT3_FRICTION, "mu_kinetic": TT3_FRICTION,
                  "tangential_stiffness": 2.0e5, "tangential_damping": 300.0},
        "gravity": True,
    }
    rest = _at_rest(robot, nodes, [(0, 1), (2, 3), (4, 5)])
    rest[:, 2] += TT3_CAP_RADIUS - rest[:, 2].min()
    rest[:, 0] -= rest[:, 0].mean()
    robot["nodes"] = {n: xyz for n, xyz in zip(names, rest.tolist())}
    return robot


def _at_rest(robot: dict[str, Any], drawing: FloatArray, rods: list[tuple[int, int]]) -> FloatArray:
    """The free ``robot``'s weightless rest shape (form-found from ``drawing``, its nodes)
    turned and moved back onto the drawing (least squares over the nodes), so the robot lies
    as drawn. Each rod (node index pairs) keeps its drawn length: the statics' stiff bars
    are some 1e-5 m shorter under their compression, the dynamics' rods rigid."""
    rest = rest_shape(robot_from_dict(robot)).nodes
    centre, rest_centre = drawing.mean(axis=0), rest.mean(axis=0)
    turn, _ = Rotation.align_vectors(drawing - centre, rest - rest_centre)
    out: FloatArray = turn.apply(rest - rest_centre) + centre
    for a, b in rods:
        mid, half = 0.5 * (out[a] + out[b]), 0.5 * (out[b] - out[a])
        half *= 0.5 * float(np.linalg.norm(drawing[b] - drawing[a])) / float(np.linalg.norm(half))
        out[a], out[b] = mid - half, mid + half
    return out


# --------------------------------------------------------------------------- six_bar
#: Rible.jl's SUPERball: bar length 2 l = 1.7 m, bar spacing d = l / 2, bar mass 5 kg, cable
#: stiffness 4000 N/m, rest length 0.996 m for all 24 cables, friction 0.9.
SB_ROD_LENGTH, SB_ROD_MASS, SB_STIFFNESS, SB_REST_LENGTH, SB_FRICTION = 1.7, 5.0, 4000.0, 0.996, 0.9
#: The caps' torsional and rolling friction lever arms [m]: MuJoCo's defaults for
#: ``condim="6"`` (``friction="1 0.005 0.0001"``; docs/robots.md).
SB_TORSIONAL_FRICTION, SB_ROLLING_FRICTION = 0.005, 0.0001


def expanded_octahedron(length: float) -> tuple[FloatArray, list[tuple[int, int]], list[tuple[int, int]]]:
    """``(nodes (12, 3), rods, cables)`` of the 6-bar icosahedron with rods of ``length``:
    nodes at the cyclic permutations of ``(0, +-L/4, +-L/2)``, rods in parallel pairs along
    each axis, cables the 24 node pairs ``sqrt(6) L / 4`` apart (the equilibrium of equal
    cable force densities)."""
    l, d = length / 2, length / 4
    nodes = np.array([[0, d, l], [0, d, -l], [0, -d, -l], [0, -d, l],
                      [d, l, 0], [d, -l, 0], [-d, -l, 0], [-d, l, 0],
                      [l, 0, d], [-l, 0, d], [-l, 0, -d], [l, 0, -d]], dtype=float)
    rods = [(0, 1), (3, 2), (4, 5), (7, 6), (9, 8), (10, 11)]
    edge = math.sqrt(6.0) * length / 4
    cables = [(i, j) for i, j in itertools.combinations(range(12), 2)
              if abs(float(np.linalg.norm(nodes[i] - nodes[j])) - edge) < 1e-9 * length]
    return nodes, rods, cables


def closed_triangles(nodes: FloatArray, cables: list[tuple[int, int]]) -> list[tuple[int, int, int]]:
    """The triangles of three mutually cabled nodes (the 6-bar's 8 equilateral faces)."""
    linked = {frozenset(c) for c in cables}
    return [t for t in itertools.combinations(range(len(nodes)), 3)
            if all(frozenset(p) in linked for p in itertools.combinations(t, 2))]


def six_bar() -> dict[str, Any]:
    """A SUPERball-like 6-bar: 6 rods of 1.7 m and 5 kg, 24 cables of 4000 N/m, every cable
    motor-driven, one IMU per rod, a floor. Drawn in its equilibrium with one closed
    triangle on the floor.

    All 24 cables are actuated (the issue allows 12 to 24): with SUPERball v1's 12 (one per
    end cap: the four closed triangles of one parity) the tipping derivation
    (:mod:`.tipping`) finds no move within the motors' range that tips the robot off a
    closed triangle of the other parity, such as the one it is drawn on (docs/robots.md)."""
    nodes, rods, cables = expanded_octahedron(SB_ROD_LENGTH)
    tris = closed_triangles(nodes, cables)
    base = next(t for t in tris if np.prod(np.sign(nodes[list(t)].mean(axis=0))) < 0)
    nodes = _on_face(nodes, list(base), 0.05)
    names = [f"n{i}" for i in range(12)]
    cable_list = [{"name": f"c{i}_{j}", "nodes": [names[i], names[j]], "rest_length": SB_REST_LENGTH, "motor": True}
                  for i, j in cables]
    return {
        "name": "six_bar",
        "description": "SUPERball-like 6-bar icosahedron tensegrity robot (after Rible.jl's SUPERball example)",
        "units": "SI",
        "nodes": {n: xyz for n, xyz in zip(names, nodes.tolist())},
        # rod radius, caps and their share of the mass chosen here (docs/robots.md)
        "rods": [{"name": f"rod{k}", "nodes": [names[a], names[b]], "mass": SB_ROD_MASS, "radius": 0.02,
                  "cap_mass": 1.0, "cap_radius": 0.05} for k, (a, b) in enumerate(rods)],
        # motor range, speed, lag and limit chosen here (docs/robots.md)
        "cable_defaults": {"stiffness": SB_STIFFNESS, "damping": 50.0,
                           "motor": {"range": [0.45, 1.05], "tau": 0.02, "max_speed": 0.5, "max_tension": 2000.0}},
        "cables": cable_list,
        "sensors": {"cable_length": "all", "cable_tension": "all", "imu": "all"},
        "floor": {"stiffness": 5.0e5, "dissipation": 5.0, "mu_static": SB_FRICTION, "mu_kinetic": SB_FRICTION,
                  "tangential_stiffness": 5.0e5, "tangential_damping": 500.0,
                  "rolling_friction": SB_ROLLING_FRICTION, "torsional_friction": SB_TORSIONAL_FRICTION},
        "gravity": True,
    }


def _on_face(nodes: FloatArray, face: list[int], cap_radius: float) -> FloatArray:
    """``nodes`` turned so that ``face``'s outward normal points down, the face's caps
    touching the floor z = 0 and its centroid above the origin."""
    c = nodes[face].mean(axis=0)
    n = np.cross(nodes[face[1]] - nodes[face[0]], nodes[face[2]] - nodes[face[0]])
    n = n / np.linalg.norm(n) * (1.0 if n @ (c - nodes.mean(axis=0)) > 0 else -1.0)
    down = np.array([0.0, 0.0, -1.0])
    axis = np.cross(n, down)
    s, cos = float(np.linalg.norm(axis)), float(n @ down)
    if s < 1e-12:
        R = np.eye(3) if cos > 0 else np.diag([1.0, -1.0, -1.0])
    else:
        k = axis / s
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        R = np.eye(3) + s * K + (1 - cos) * (K @ K)
    out: FloatArray = nodes @ R.T
    out[:, :2] -= out[face, :2].mean(axis=0)
    out[:, 2] += cap_radius - out[face, 2].mean()
    return out


# --------------------------------------------------------------------------- spine
#: The spine's cord motor: a ROBOTIS Dynamixel XL430-W250 (emanual.robotis.com/docs/en/dxl/x/
#: xl430-w250: stall torque 1.5 N m and no-load speed 61 rev/min at 12 V) winding its cord on
#: a spool of radius 10 mm (chosen here): it holds at most 1.5 / 0.01 = 150 N, and reels at
#: most 61 / 60 x 2 pi x 0.01 = 0.064 m/s unloaded.
SPINE_STALL_TORQUE, SPINE_SPOOL_RADIUS = 1.5, 0.01
SPINE_MAX_TENSION = SPINE_STALL_TORQUE / SPINE_SPOOL_RADIUS
#: The motors' slew limit [m/s], below the no-load reel speed (the model does not slow a
#: loaded reel: a motor's linear torque-speed line is not modelled).
SPINE_MAX_SPEED = 0.05


def spine() -> dict[str, Any]:
    """The C-shaped tensegrity spine of ``spine_release`` (10 vertebrae of 0.05 kg, the lowest
    fixed; cords of EA = 500 N, so each cord's stiffness is ``500 / l0``): its 36 side cords
    (groups +x, -x, +y, -y between consecutive vertebrae) motor-driven within 0.3 .. 1.2 of
    the vertebrae's spacing, its 36 diagonal cords passive; an IMU on the top vertebra.

    Drawn at its rest shape without weight (form-found from ``spine_release``'s drawing,
    which is not an equilibrium of these rest lengths: there the +x cords would pull 333 N),
    so every motor starts within its tension limit ``SPINE_MAX_TENSION`` (the +x cords hold
    112 N, the most)."""
    s = tensegrity_spine(10, shape="C", EA=500.0)
    rest = form_find(s, strict=True)
    names = s.node_names
    cables = []
    for i, name in enumerate(s.member_names):
        a, b = (names[j] for j in s.members[i])
        l0, spacing = float(s.rest_lengths[i]), float(s.initial_lengths[i])
        entry: dict[str, Any] = {"name": name, "nodes": [a, b], "stiffness": 500.0 / l0, "rest_length": l0}
        if name.startswith("side"):
            entry["motor"] = {"range": [0.3 * spacing, 1.2 * spacing]}
        cables.append(entry)
    bodies = [{"name": b.name, "nodes": [names[j] for j in b.nodes], "mass": 0.05} | (
        {"fixed": True} if b.fixed else {}) for b in s.bodies]
    return {
        "name": "spine",
        "description": "the C-shaped tensegrity spine of spine_release with motor-driven side cords",
        "units": "SI",
        "nodes": {n: xyz for n, xyz in zip(names, rest.nodes.tolist())},
        # cord damping and motor lag chosen here, speed and limit from the motor (docs/robots.md)
        "cable_defaults": {"damping": 0.5, "motor": {"range": [0.01, 0.1], "tau": 0.05, "max_speed": SPINE_MAX_SPEED,
                                                     "max_tension": SPINE_MAX_TENSION}},
        "cables": cables,
        "rigid_bodies": bodies,
        "sensors": {"cable_length": "all", "cable_tension": "all", "imu": ["vertebra9"]},
        "gravity": True,
    }
