"""A robot's sizes outside the range the dynamics carry are refused through the CLI in one
line naming the key, its unit and the accepted range (docs/robots.md, "Sizes"): exit 2,
nothing simulated. Inside the range every size is drawn by tests/robot/test_drawn_robots.py."""

from __future__ import annotations

import pytest
import yaml

from tensegrity_ros.cli import main

ROBOT = {"nodes": {"a": [0.0, 0.0, 1.0], "b": [1.0, 0.0, 1.0], "p": [0.0, 1.0, 1.0]},
         "rods": [{"name": "r", "nodes": ["a", "b"], "mass": 1.0, "radius": 0.01}],
         "cables": [{"name": "c", "nodes": ["a", "p"], "stiffness": 10.0},
                    {"name": "d", "nodes": ["b", "p"], "stiffness": 10.0}],
         "masses": {"p": 1.0}, "floor": {"stiffness": 1.0e4, "mu_static": 0.5}}


def _scene(tmp_path, robot: dict, effects=("inertia", "cables"), **extra) -> str:
    scene = {"model": {"kind": "robot", "robot": robot}, "initial": {"drawn": True}, "effects": list(effects),
             "duration": 0.01, **extra}
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    return str(path)


def _with(path: tuple, value) -> dict:
    robot = yaml.safe_load(yaml.safe_dump(ROBOT))
    target = robot
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return robot


@pytest.mark.parametrize(("path", "value", "key", "unit"), [
    (("rods", 0, "mass"), 1e-300, "model.robot.rods[0].mass", "kg"),
    (("rods", 0, "radius"), 1e-16, "model.robot.rods[0].radius", "m"),
    (("masses", "p"), 1e-20, "model.robot.masses.p", "kg"),
    (("cables", 1, "stiffness"), 1e-300, "model.robot.cables[1].stiffness", "N/m"),
    (("floor", "stiffness"), 5e-16, "model.robot.floor.stiffness", "N/m"),
])
def test_a_size_below_the_least_is_one_line_naming_key_unit_and_range(tmp_path, capsys, path, value, key, unit):
    assert main(["simulate", _scene(tmp_path, _with(path, value))]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert key in err[0] and f"{value:g} {unit}" in err[0] and f"[1e-15, 1e+15] {unit}" in err[0], err


def test_a_scene_s_override_below_the_least_is_one_line(tmp_path, capsys):
    scene = _scene(tmp_path, ROBOT, effects=["inertia", "cables", {"contact": {"stiffness": 1e-300}}])
    assert main(["simulate", scene]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "effects[2].contact.stiffness" in err[0] and "[1e-15, 1e+15] N/m" in err[0], err


def test_a_rod_too_slender_for_double_precision_is_one_line(tmp_path, capsys):
    """A 100 m rod of 1 um caps carrying 1 kg on each: I_a / I_t = 8e-18, whose inertia could
    not be inverted (a traceback before the check)."""
    robot = {"nodes": {"a": [0.0, 0.0, 0.0], "b": [100.0, 0.0, 0.0], "p": [50.0, 10.0, 0.0]},
             "rods": [{"name": "long", "nodes": ["a", "b"], "mass": 0.1, "radius": 0.0, "cap_mass": 0.05,
                       "cap_radius": 1e-6}],
             "cables": [{"name": "c", "nodes": ["a", "p"], "stiffness": 1.0}], "masses": {"a": 1.0, "b": 1.0, "p": 1.0}}
    assert main(["simulate", _scene(tmp_path, robot)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "model.robot.rods[0].cap_radius" in err[0] and "below 1e-12 of its transverse" in err[0]


def test_a_controller_faster_than_the_step_is_one_line(tmp_path, capsys):
    scene = {"model": {"kind": "robot", "robot": "six_bar"}, "initial": {"drawn": True},
             "control": {"roll": {"faces": 1, "rate": 5000}}, "effects": ["inertia", "cables"], "duration": 1.0}
    path = tmp_path / "fast.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    assert main(["simulate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "control.roll.rate" in err[0] and "(0, 1000] Hz" in err[0], err
