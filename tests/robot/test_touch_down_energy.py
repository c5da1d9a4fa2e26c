"""Energy at touch-down (issue 29: contacts never add energy), over the accepted range.

A robot's forces switch inside a fixed step: a cap meets or leaves the floor, a cable goes
taut or slack. RK4 across such a switch weighs the new force like Simpson's rule and, for a
cap meeting a floor of stiffness ``k`` at ``v``, gains up to ``k v^2 h^2 / 24`` [J] of
spurious work (``theta = 1/2`` into the step; docs/design/robots.md, "Switches inside a
step"). The steps are now integrated in smooth pieces between the located switches
(:mod:`tensegrity_core.sim.general.robot.step_loops`), so what is left is RK4 on smooth
pieces, whose energy error on a mode of ``omega`` [rad/s] inside its stability region is
the factor ``|R(i h omega)|^2 = 1 - (h omega)^6/72 + (h omega)^8/576 <= 1`` of the mode's
energy: it never rises on a linear mode, and the pieces' nonlinear terms (the cables'
geometry, the rods' turning) enter only at the local error's order, ``(h omega)^5 / 120``
of the energy of motion. The tests drop the three-bar robot, drawn turned in any
orientation, over the accepted range of rod mass, cable and floor stiffness and drop height:

- lossless (no dissipation, no damping, no friction): the energy ``E`` changes by no more
  than that local error over a step, ``|E_{n+1} - E_n| <= (h omega)^5 / 120 E_m + rounding``,
  ``omega`` a bound of the fastest root (the floor's and the cables' springs and dampers on
  the lightest cap), ``E_m`` the energy of motion the drop can release (its weight over its
  height above the floor, the cables' stored energy);
- with the floor's dissipation and the cables' damping it never rises by more than that.

Each fails on the scheme that stepped across the switches (the old kernels): a touch-down's
``k v^2 h^2 / 24``. Cost: 10 + 6 examples, about 1.3 s (``--durations``).
"""

from __future__ import annotations

import copy
import re

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tensegrity_core.sim import SceneError, compile_scene, load_scene

from .test_parameter_range import BASE, CAP, G, decades, robot

DURATION = 0.3


def turned(description: dict, rotvec: list[float]) -> dict:
    """``description`` with its nodes turned by ``rotvec`` [rad] about their centroid, its
    lowest cap then touching the floor ``z = 0``."""
    out = copy.deepcopy(description)
    names = list(out["nodes"])
    X = np.array([out["nodes"][k] for k in names], dtype=float)
    X = (X - X.mean(axis=0)) @ Rotation.from_rotvec(rotvec).as_matrix().T
    X[:, 2] += CAP - X[:, 2].min()
    out["nodes"] = {k: [float(v) for v in x] for k, x in zip(names, X)}
    return out


def drop(mass: float, k: float, k_floor: float, lift: float, rotvec: list[float], c: float, d: float):
    """``(model, energies per step, the energy of motion [J], a bound [rad/s] of its fastest
    root)`` of the three-bar robot dropped; None where the step check refuses the scene (one
    line, as tests/robot/test_parameter_range.py checks). The bound: a cap of the lightest
    effective mass ``m`` (its rod turning about its centre with it) on every spring and
    damper that can act on it at once, the floor (stiffened to ``k (1 + d v)`` at the
    touch-down's speed) and the rod's four motor and two passive cables: ``sqrt(sum k / m)``,
    or the damping rate ``sum c / m`` where larger (an overdamped root)."""
    description = turned(robot(mass, k, c, k_floor, d, 0.0), rotvec)
    data = {"name": "drop", "model": {"kind": "robot", "robot": description},
            "initial": {"drawn": True, "lift": lift}, "duration": DURATION,
            "effects": ["inertia", "cables", "gravity", "contact"]}
    try:
        model = compile_scene(load_scene(data))
    except SceneError as err:
        assert re.match(r"^integrator\.max_step: ", str(err)), str(err)
        return None
    h = model.step
    samples: list = []
    model.record(model.initial_state(t_end=DURATION), np.arange(int(round(DURATION / h)) + 1) * h, samples)
    seen = model.observe(samples)
    energy = seen["kinetic_energy"] + seen["potential_energy"]
    total = 3 * mass
    lengths = seen["member_lengths"][0, 3:]
    rest = seen["member_rest_lengths"][0, 3:]
    stiffness = np.array([k] * 6 + [k / 10] * 3)
    stored = float(np.sum(0.5 * stiffness * np.maximum(lengths - rest, 0.0) ** 2))
    motion = total * G * (seen["centre_of_mass"][0, 2] - CAP) + stored
    # the lightest a cap can be (the rod turning about its centre with it), on every spring and
    # damper that can act on it at once: the floor and all the rod's cables
    rod = BASE["rods"][0]
    inertia = rod["inertia"][0] * mass / rod["mass"]
    half = 0.5 * float(np.linalg.norm(np.subtract(*(description["nodes"][n] for n in rod["nodes"]))))
    m_cap = 1.0 / (1.0 / mass + half**2 / inertia)
    springs = k_floor * (1.0 + d * np.sqrt(2.0 * G * lift)) + 4 * k + 2 * k / 10
    return model, energy, motion, float(max(np.sqrt(springs / m_cap), 6 * c / m_cap))


def local_error(h: float, omega: float, motion: float, energy: np.ndarray) -> float:
    """RK4's local error on a piece, ``(h omega)^5 / 120`` of the energy of motion, plus the
    rounding of the energy's terms (64 ulp of their size)."""
    return (h * omega) ** 5 / 120 * motion + 64 * np.finfo(float).eps * np.abs(energy).max()


rotations = st.lists(st.floats(-np.pi, np.pi), min_size=3, max_size=3)


@settings(max_examples=10, deadline=None)
@given(mass=decades(0.05, 50), k=decades(50, 2e4), k_floor=decades(1e3, 1e7), lift=st.floats(0.0, 0.3),
       rotvec=rotations)
def test_a_lossless_drop_keeps_its_energy_to_rk4_s_local_error(mass, k, k_floor, lift, rotvec):
    got = drop(mass, k, k_floor, lift, rotvec, c=0.0, d=0.0)
    if got is None:
        return
    model, energy, motion, omega = got
    step = np.abs(np.diff(energy)).max()
    assert step <= local_error(model.step, omega, motion, energy), (step, motion, model.step * omega)


@settings(max_examples=6, deadline=None)
@given(mass=decades(0.05, 50), k=decades(50, 2e4), k_floor=decades(1e3, 1e7), lift=st.floats(0.0, 0.3),
       rotvec=rotations, c=st.sampled_from([1.0, 50.0]), d=st.sampled_from([0.5, 5.0]))
def test_with_dissipation_a_drop_s_energy_never_rises(mass, k, k_floor, lift, rotvec, c, d):
    got = drop(mass, k, k_floor, lift, rotvec, c=c, d=d)
    if got is None:
        return
    model, energy, motion, omega = got
    assert np.diff(energy).max() <= local_error(model.step, omega, motion, energy)
