"""Robot scenes: the issue's bad input, one clear line each through the scene reader and the
CLI (nothing simulated); overrides of the floor and motors reach the model."""

from __future__ import annotations

import copy

import pytest

from tensegrity_core.sim import SceneError, compile_scene, load_scene
from tensegrity_ros.cli import main

BASE = {"name": "t", "model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
        "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction"], "duration": 0.1}
INLINE = {"name": "r", "nodes": {"a": [0.0, 0.0, 0.1], "b": [1.0, 0.0, 0.1]},
          "rods": [{"name": "r", "nodes": ["a", "b"], "mass": 1.0, "radius": 0.01, "cap_radius": 0.05,
                    "inertia": [0.1, 0.001]}],
          "cables": [{"name": "c", "nodes": ["a", "b"], "stiffness": 10.0, "rest_length": 0.5}],
          "floor": {"stiffness": 1.0e5, "dissipation": 1.0, "mu_static": 0.5, "mu_kinetic": 0.4,
                    "tangential_stiffness": 1.0e4, "tangential_damping": 10.0}}


def _scene(**changes):
    d = copy.deepcopy(BASE)
    d.update(changes)
    return d


def _robot(**changes):
    r = copy.deepcopy(INLINE)
    for k, v in changes.items():
        r["rods"][0][k] = v
    return r


BAD = {
    "rest length out of range": (_scene(inputs={"td_0": {"law": "constant", "value": 0.9}}),
                                 "inputs.td_0: rest length 0.9 m of cable 'td_0' is outside its motor's range"),
    "NaN": (_scene(inputs={"td_0": {"law": "constant", "value": float("nan")}}), "inputs.td_0.value: must be finite"),
    "negative stiffness": (_scene(effects=["inertia", "cables", {"contact": {"stiffness": -1.0}}]),
                           "effects[2].contact.stiffness: must be > 0 N/m, got -1.0 N/m"),
    "rod of zero length": (_scene(model={"kind": "robot", "robot": {**INLINE, "nodes": {"a": [0, 0, 0.1],
                                                                                          "b": [0, 0, 0.1]}}}),
                           "rod 'r' has zero length"),
    "friction < 0": (_scene(effects=["inertia", "cables", "contact", {"friction": {"mu_static": -0.2}}]),
                     "effects[3].friction.mu_static: must be >= 0 (dimensionless), got -0.2"),
    "starts inside the floor": (_scene(model={"kind": "robot", "robot": {**INLINE, "nodes": {
        "a": [0, 0, 0.02], "b": [1, 0, 0.1]}}}), "cap 'a' of rod 'r' starts 0.03 m inside the floor"),
    "friction without contact": (_scene(effects=["inertia", "cables", "friction"]),
                                 "effect 'friction' needs 'contact'"),
    "a robot effect in a general scene": ({"model": {"kind": "general", "structure": "structures/spine_c_cords.yaml"},
                                           "initial": {"drawn": True}, "effects": ["inertia", "springs", "contact"],
                                           "duration": 0.1}, "effect 'contact' applies to robot scenes only"),
    "variable steps": (_scene(integrator={"method": "DOP853"}), "a robot scene integrates with fixed RK4 steps"),
    "control: no face": (_scene(control={"roll": {"faces": 0}}), "control.roll.faces: must be an integer >= 1, got 0"),
    "control: zero heading": (_scene(control={"roll": {"faces": 1, "heading": [0, 0]}}),
                              "control.roll.heading: must be a nonzero direction (x, y) on the floor, got [0.0, 0.0]"),
    "control: 3-d heading": (_scene(control={"roll": {"faces": 1, "heading": [1, 0, 0]}}),
                             "control.roll.heading: must be a list of 2 numbers"),
    "control: rate 0": (_scene(control={"roll": {"faces": 1, "rate": 0}}), "control.roll.rate: must be > 0 Hz, got 0 Hz"),
    "control: unknown key": (_scene(control={"roll": {"faces": 1, "speed": 0.2}}), "control.roll.speed: unknown key 'speed'; allowed: faces, heading, rate"),
    "control: unknown gait": (_scene(control={"rol": {"faces": 1}}), "control.rol: unknown key 'rol' (did you mean 'roll'?)"),
    "control with inputs": (_scene(control={"roll": {"faces": 1}}, inputs={"td_0": 0.3}),
                            "control: the closed-loop gait commands every motor: give 'control' or 'inputs', not both"),
    "control of a general scene": ({"model": {"kind": "general", "structure": "structures/spine_c_cords.yaml"},
                                    "initial": {"drawn": True}, "effects": ["inertia", "springs"], "duration": 0.1,
                                    "control": {"roll": {"faces": 1}}},
                                   "control: 'control' applies to robot scenes only (model kind 'robot'), not 'general'"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_is_one_clear_line(case):
    data, expected = BAD[case]
    with pytest.raises(SceneError) as err:
        from tensegrity_core.sim.scene import SCENES_DIR, scene_from_dict
        scene_from_dict(data, base=SCENES_DIR)
    message = str(err.value)
    assert "\n" not in message and expected in message, message


def test_bad_input_through_the_cli_exits_2_with_one_line(tmp_path, capsys):
    import yaml
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(BAD["friction < 0"][0]))
    assert main(["simulate", str(bad), "-o", str(tmp_path / "out.npz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "mu_static: must be >= 0 (dimensionless), got -0.2" in err[0] and err[0].startswith("error: bad.yaml")
    assert not (tmp_path / "out.npz").exists()


def test_overrides_reach_the_model():
    """A sweep varies friction, contact and motor parameters through the scene's effects."""
    scene = load_scene(_scene(effects=["inertia", "cables", {"motors": {"tau": 0.25, "max_speed": 0.1}}, "gravity",
                                       {"contact": {"stiffness": 3.0e5}},
                                       {"friction": {"mu_static": 0.7, "mu_kinetic": 0.5}}]))
    plan = compile_scene(scene).plan
    assert list(plan.floor_params[:4]) == [3.0e5, 5.0, 0.7, 0.5]          # dissipation: the description's
    assert set(plan.motor_tau) == {0.25} and set(plan.motor_speed) == {0.1}


def test_a_robot_file_named_by_a_scene_travels_to_sweep_workers_inlined(tmp_path, monkeypatch):
    import shutil

    import yaml

    from tensegrity_core.robot.loading import robot_path
    from tensegrity_core.sim.scene.references import self_contained
    shutil.copy(robot_path("three_bar"), tmp_path / "mine.yaml")
    doc = _scene(model={"kind": "robot", "robot": "mine.yaml"})
    out = self_contained(doc, tmp_path)
    inlined = out["model"]["robot"]
    assert inlined == yaml.safe_load((tmp_path / "mine.yaml").read_text())   # the file's description itself
    monkeypatch.chdir(tmp_path.parent)                  # a worker elsewhere needs no file
    assert load_scene(out).model.robot.name == "three_bar"
    assert self_contained(BASE, tmp_path)["model"]["robot"]["name"] == "three_bar"   # a shipped name too


@pytest.mark.parametrize("scene", ["six_bar_drop", "spine_bend"])
def test_the_joint_sample_is_the_observations_joint_part_to_the_last_bit(scene):
    """``joint_sample`` (one evaluation) gives what ``observe_now`` gives for the joints and
    the motor cables, bit for bit, in motion (60 steps of 1 ms under the scene's inputs);
    without the coordinates, the same motor cables and no ``q``, ``qdot``."""
    import numpy as np

    from tensegrity_core.sim import Simulator
    from tensegrity_core.sim.sampled import step_time

    sim = Simulator(scene)
    held = [0.0 if v != v else v for v in sim.command]          # inputs with a law: placeholders
    for k in range(60):
        sim.set_command(held)
        sim.advance(step_time(k + 1, 1_000_000))
    full, joints = sim.model.observe_now(sim.state), sim.model.joint_sample(sim.state)
    cables = sim.model.joint_sample(sim.state, coordinates=False)
    for key in ("q", "qdot", "applied_forces", "end_effector"):
        np.testing.assert_array_equal(joints[key], full[key])
    assert cables["q"].size == cables["qdot"].size == 0
    driven = list(sim.interface.members)
    for key, member_key in (("actuated_lengths", "member_lengths"), ("actuated_rates", "member_rates"),
                            ("actuated_forces", "member_forces")):
        np.testing.assert_array_equal(joints[key], full[member_key][driven])
        np.testing.assert_array_equal(cables[key], full[member_key][driven])
    assert np.abs(full["qdot"]).max() > 1e-3                     # it moves
