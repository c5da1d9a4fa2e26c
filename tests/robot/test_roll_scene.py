"""A scene with ``control: {roll: ...}`` run by ``tensegrity simulate``: the robot rolls
exactly the faces asked for, counted from the written trajectory's contact forces by
:mod:`tensegrity_core.robot.faces` (independently of the controller), and ends resting on
the last one; the output is at the scene's output rate, not the control rate."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from tensegrity_core.robot.faces import faces_rolled, faces_visited
from tensegrity_core.sim import Trajectory, load_scene
from tensegrity_ros.cli import main


def _faces(path):
    """Faces rolled, and the faces rested on [(t [s], caps)], from a trajectory file."""
    traj = Trajectory.from_npz(path)
    faces = faces_visited(traj.times, np.asarray(traj.contact_forces) > 0.0)
    return traj, faces_rolled(faces), faces


def _run(scene, out, capsys):
    assert main(["simulate", str(scene), "-o", str(out), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_the_shipped_closed_loop_scene_rolls_two_faces(tmp_path, capsys):
    """six_bar_roll_closed_loop asks for 2 faces towards +x: 2 rolled, resting on the second
    for the last second, the centre of the caps on the floor moved along +x; samples every
    1 / output.rate."""
    scene = load_scene("six_bar_roll_closed_loop")
    assert scene.control is not None and scene.control.faces == 2
    summary = _run("six_bar_roll_closed_loop", tmp_path / "roll.npz", capsys)
    traj, rolled, faces = _faces(tmp_path / "roll.npz")
    assert summary["success"] and rolled == 2, faces
    assert faces[-1][0] < scene.duration - 1.0
    assert np.allclose(np.diff(traj.times), 1.0 / scene.output_rate)
    x = np.asarray(traj.nodes)[:, :, 0].mean(axis=1)
    assert x[-1] - x[0] > 0.4                       # metres: ~0.5 m a face


def test_a_scene_file_rolls_one_face_towards_its_heading(tmp_path, capsys):
    """A scene file asking for 1 face towards (-1, 1) at 25 Hz: 1 rolled, the robot moved
    towards that heading."""
    data = {"model": {"kind": "robot", "robot": "six_bar"}, "initial": {"drawn": True},
            "control": {"roll": {"faces": 1, "heading": [-1, 1], "rate": 25}},
            "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"],
            "output": {"rate": 50}, "duration": 5.0}
    scene = tmp_path / "one.yaml"
    scene.write_text(yaml.safe_dump(data))
    _run(scene, tmp_path / "one.npz", capsys)
    traj, rolled, faces = _faces(tmp_path / "one.npz")
    assert rolled == 1, faces
    moved = np.asarray(traj.nodes)[-1, :, :2].mean(axis=0) - np.asarray(traj.nodes)[0, :, :2].mean(axis=0)
    assert moved @ np.array([-1.0, 1.0]) / np.sqrt(2.0) > 0.2


@pytest.mark.parametrize("bad", ["faces: 0", "faces: 1, heading: [0, 0]"])
def test_bad_control_through_the_cli_is_one_line(tmp_path, capsys, bad):
    scene = tmp_path / "bad.yaml"
    scene.write_text(f"model: {{kind: robot, robot: six_bar}}\ninitial: {{drawn: true}}\n"
                     f"control: {{roll: {{{bad}}}}}\neffects: [inertia, cables]\nduration: 1.0\n")
    assert main(["simulate", str(scene)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "control.roll." in err[0] and "line 3" in err[0], err


def test_the_stepping_simulator_refuses_a_scene_under_control_in_one_line(capsys):
    """The stepping API (and so the ROS node and the view) cannot run the scene's controller:
    it refuses the scene, naming what runs it, rather than stepping it with the motors idle."""
    from tensegrity_core.sim import SimulationError, Simulator

    with pytest.raises(SimulationError, match=r"closed-loop gait \(control.roll\).*tensegrity simulate "
                                              r"six_bar_roll_closed_loop.*tensegrity gait six_bar roll"):
        Simulator("six_bar_roll_closed_loop")
    assert main(["view", "--scene", "six_bar_roll_closed_loop"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "control.roll" in err[0], err
