"""Every shipped robot works within its own motors: at its statics rest shape and along each
of its shipped scenes, every motor cable's tension is at most its motor's tension limit and
its rest length inside the motor's range.

Along a run the scene's tension limit is lifted (``max_tension: .inf``), so a motor that the
robot would back-drive shows as a tension past the robot's own limit instead of paying out
quietly; the run otherwise is the shipped scene's."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from tensegrity_core.robot.loading import load_robot, robot_names
from tensegrity_core.robot.statics import rest_shape
from tensegrity_core.sim import load_scene, simulate
from tensegrity_core.sim.scene.reader import scene_names, scene_path

#: Per shipped robot, the loads of its statics rest shape: free robots without weight (they
#: have no equilibrium under gravity without a floor), the spine also on its fixed base under
#: gravity.
REST_SHAPES = {"three_bar": [False], "six_bar": [False], "spine": [False, True]}


def _robot_scenes() -> dict[str, dict]:
    docs = {name: yaml.safe_load(scene_path(name).read_text()) for name in scene_names()}
    return {name: d for name, d in docs.items() if d["model"]["kind"] == "robot"}


ROBOT_SCENES = _robot_scenes()


def test_every_shipped_robot_and_robot_scene_is_checked():
    assert sorted(REST_SHAPES) == robot_names()
    assert {d["model"]["robot"] for d in ROBOT_SCENES.values()} == set(robot_names())


@pytest.mark.parametrize(("name", "gravity"), [(n, g) for n, gs in REST_SHAPES.items() for g in gs])
def test_rest_shape_tensions_are_within_the_motors_limits(name, gravity):
    robot = load_robot(name)
    shape = rest_shape(robot, gravity=gravity)
    mot = robot.motors
    tension = shape.member_forces[robot.cable_members()][mot.cable]
    rest = robot.cables.rest_length[mot.cable]
    assert np.all(tension <= mot.max_tension), (tension - mot.max_tension).max()
    assert np.all((mot.range[:, 0] <= rest) & (rest <= mot.range[:, 1]))


def _unlimited(effects: list) -> list:
    """``effects`` with the motors' tension limit lifted (ideal motors stay ideal)."""
    out = []
    for e in effects:
        if e == "motors" or (isinstance(e, dict) and "motors" in e):
            e = {"motors": {**(e["motors"] if isinstance(e, dict) else {}), "max_tension": math.inf}}
        out.append(e)
    return out


@pytest.mark.parametrize("scene", sorted(ROBOT_SCENES))
def test_shipped_scene_runs_stay_within_the_motors_limits(scene):
    doc = ROBOT_SCENES[scene]
    robot = load_robot(doc["model"]["robot"])
    run = simulate(load_scene(dict(doc, effects=_unlimited(doc["effects"]))))
    assert run.success
    mot = robot.motors
    by_cable = {int(c): i for i, c in enumerate(mot.cable)}
    motor = np.array([by_cable[int(c)] for c in robot.cables.actuated])     # applied_forces' columns
    tension = run.member_forces[:, len(robot.rods) + robot.cables.actuated]
    assert np.all(tension <= mot.max_tension[motor]), f"{(tension - mot.max_tension[motor]).max():.1f} N over"
    rest = run.applied_forces
    assert np.all((mot.range[motor, 0] <= rest) & (rest <= mot.range[motor, 1]))
