"""Drawn robots and robot scenes in MuJoCo: over the whole range a description accepts, the
export writes a model MuJoCo loads with the project's masses and forces, or refuses in one
line what MuJoCo cannot take.

The robots and scenes are those of ``tests/robot/test_drawn_robots.py`` (masses, stiffnesses,
damping and the floor's parameters over 1e-15 to 1e15 of their unit, slender rods of radius 0,
point masses riding on caps and body nodes, free and pinned point masses, a moving or fixed
rigid triangle, motors in every mode). Each is exported as a description (its own floor,
gravity and motors) and as a scene (the scene's effects and overrides). MuJoCo is the
independent side: its parser and compiler, its tendon and actuator laws, its own mass
matrix; the project's side is the robot back end's plan and evaluation, which the exporter
does not use.

- **Loads or refuses.** ``mj_loadXML`` compiles every exported model. A refusal is one line
  naming the rod (``rods[i].inertia``) or body (``rigid_bodies[j]``) whose principal inertia,
  computed independently from the back end's plan, is below MuJoCo's floor: ``mjMINVAL``
  (1e-15 kg m^2, a ``diaginertia``) or ``mjEPS`` (1e-14 kg m^2, a ``fullinertia``).
- **Masses.** Each body's mass, first moment and inertia about its reference point (the
  rod's centre, the body's node centroid: the mean of its node sites in MuJoCo) are the
  plan's, to rounding (a rigid body's tensor carries the documented isotropic 1e-12 of its
  trace); point masses riding on caps and body nodes included.
- **Forces.** At the exported state (the keyframe: as drawn, at rest, motors held) MuJoCo's
  smooth generalised forces (``qfrc_smooth``: tendons' springs with their dead band, the
  motors' actuators, gravity) equal the project's cable tensions and weights summed on each
  body and free coordinate. Rounding: a cable's length is a difference of positions placed
  by a rotation, good to ``64 eps`` of the drawing's size ``X``, so its tension to ``k 64 eps
  X`` (plus ``1e-12`` of itself); a moment adds the arm.

Contact is not compared here (a drawn floor touches the lowest cap at depth 0, where
MuJoCo's soft constraint and the project's Hunt-Crossley contact differ by design:
docs/mujoco.md, "Robots"); the rest contact is checked in ``test_robot_mujoco.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.export import ExportError, export_mjcf
from tensegrity_core.export.mujoco_limits import MJEPS, MJMINVAL
from tensegrity_core.export.robot_mjcf import INERTIA_MARGIN
from tensegrity_core.robot.layout import robot_layout
from tensegrity_core.robot.robot_schema import robot_from_dict
from tensegrity_core.sim import compile_scene, load_scene
from tests.mujoco_peer import body_force_expectation
from tests.robot.test_drawn_robots import ALL, scenes, stable_step

EPS = np.finfo(float).eps


@pytest.fixture(autouse=True, scope="module")
def warnings_kept():
    """MuJoCo's warnings (an inertia too close to singular to factorise, at mass ratios of up
    to 1e28 here, which the smooth forces compared do not use) into a list rather than its log
    file in the working folder."""
    import mujoco

    kept: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(kept.append)
    yield kept
    mujoco.set_mju_user_warning(previous)


def project_model(robot: dict, effects: list):
    return compile_scene(load_scene({"name": "drawn", "model": {"kind": "robot", "robot": robot},
                                     "initial": {"drawn": True}, "effects": effects, "duration": 1.0,
                                     "integrator": {"max_step": stable_step(robot, effects)}}))


def about_com(mass: float, first: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """An inertia tensor about a frame's origin moved to the centre of mass ``first / mass``."""
    c = first / mass
    return inertia - mass * (float(c @ c) * np.eye(3) - np.outer(c, c))


@settings(max_examples=100, deadline=None)
@given(scene=scenes(), as_scene=st.booleans())
def test_a_drawn_robot_exports_with_the_projects_masses_and_forces_or_says_why_not(scene, as_scene):
    import mujoco

    robot_data, effects = scene
    if not as_scene:
        effects = ALL                               # the description's own floor, gravity and motors
    model = project_model(robot_data, effects)
    p = model.plan
    robot = robot_from_dict(robot_data)
    source = load_scene({"name": "drawn", "model": {"kind": "robot", "robot": robot_data}, "initial": {"drawn": True},
                         "effects": effects, "duration": 1.0,
                         "integrator": {"max_step": stable_step(robot_data, effects)}}) if as_scene else robot
    lay = robot_layout(robot)
    nr = len(robot.rods)
    # the least principal inertia of each body about its centre of mass, from the plan
    least = [float(np.linalg.eigvalsh(about_com(p.body_mass[s], p.body_first_moment[s], p.body_inertia[s])).min())
             for s in range(len(p.body_dof))]
    floors = [MJMINVAL if s < nr else MJEPS for s in range(len(p.body_dof))]
    try:
        exported = export_mjcf(source)
    except ExportError as err:
        text = str(err)
        assert "\n" not in text
        named = [s for s in range(len(p.body_dof))
                 if (f"rods[{s}].inertia" if s < nr else f"body {lay.body_names[s]!r}") in text]
        assert len(named) == 1, text
        s = named[0]
        assert least[s] < floors[s] * (1 + 1e-6), (text, least[s])
        return
    assert all(x >= f * (1 - 1e-6) for x, f in zip(least, floors))
    m = mujoco.MjModel.from_xml_string(exported.xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    mujoco.mj_forward(m, d)
    ev = model.system.evaluate(model.y0[None])
    X = ev.positions[0]
    size = float(np.abs(X).max()) + float(np.ptp(X, axis=0).max())
    # -- masses: each body's mass, first moment and inertia about its reference point (the rod's
    # centre, the body's node centroid: the mean of its node sites), in the world's axes
    for s in range(len(p.body_dof)):
        name = lay.body_names[s]
        b = m.body(f"rod:{name}" if s < nr else f"body:{name}").id
        ref = np.mean([d.site(f"node:{robot.node_names[i]}").xpos for i in lay.body_nodes[s]], axis=0)
        mass, r = float(m.body_mass[b]), d.xipos[b] - ref
        R = d.ximat[b].reshape(3, 3)
        inertia = R @ np.diag(m.body_inertia[b]) @ R.T + mass * (float(r @ r) * np.eye(3) - np.outer(r, r))
        scale = float(np.trace(p.body_inertia[s]))
        assert mass == pytest.approx(p.body_mass[s], rel=1e-12)
        np.testing.assert_allclose(mass * r, p.body_first_moment[s], rtol=0, atol=1e-12 * p.body_mass[s] * size)
        np.testing.assert_allclose(inertia, p.body_inertia[s], rtol=0,
                                   atol=(1e-10 + (INERTIA_MARGIN if s >= nr else 0.0)) * scale)
    # -- forces: the cables' tensions and the weights summed on each body and free coordinate
    T = ev.tensions[0]
    u = X[p.cable_b] - X[p.cable_a]
    length = np.linalg.norm(u, axis=1)
    u = np.divide(u, length[:, None], out=np.zeros_like(u), where=length[:, None] > 0)
    nodal = p.external.copy()
    np.add.at(nodal, p.cable_a, T[:, None] * u)
    np.add.at(nodal, p.cable_b, -T[:, None] * u)
    err = 1e-12 * np.abs(T) + p.cable_k * 64 * EPS * (size + length)        # each tension's rounding [N]
    rounding = 1e-12 * np.abs(p.external).sum(axis=1)
    np.add.at(rounding, p.cable_a, err)
    np.add.at(rounding, p.cable_b, err)
    expected, tolerance = np.zeros(m.nv), np.zeros(m.nv)
    for s in range(len(p.body_dof)):
        name = lay.body_names[s]
        b = m.body(f"rod:{name}" if s < nr else f"body:{name}").id
        idx = np.flatnonzero(lay.node_body == s)
        v, force, allowance = body_force_expectation(m, d, b, nodal[idx], rounding[idx], X[idx], size)
        expected[v:v + 6], tolerance[v:v + 6] = force, allowance
    for node, axis in zip(p.free_node, p.free_axis):
        v = m.jnt_dofadr[m.joint(f"node:{robot.node_names[node]}:{'xyz'[axis]}").id]
        expected[v], tolerance[v] = nodal[node, axis], rounding[node]
    got = d.qfrc_smooth
    assert np.all(np.abs(got - expected) <= tolerance), (got, expected, tolerance)
