"""`tensegrity move` and `tensegrity follow` against a running controller (issue 15), and
the IK node reading the mechanism from the scene (one source of parameters).

The commands run in this process (:func:`tests.ros_support.run_cli_here`: what they print
and their exit codes, without an interpreter start each, ~1.5 s of CPU); the one whose claim
is the process's whole stderr (no controller: one line) runs as its own process."""

from __future__ import annotations

import json
import math

import pytest
import yaml

from tensegrity_core.class2 import Class2Params, forward_kinematics, inverse_kinematics
from tests.ros_support import run_cli, run_cli_here

pytestmark = pytest.mark.ros

NS = ("--ros-args", "-r", "__ns:=/ctl_cli")


@pytest.mark.parametrize("text, words", [
    ("time,rho1\n1,0.7\n", "missing rho2"),
    ("time,rho1,rho2\n1,0.7,abc\n", "'abc' is not a number"),
    ("time,rho1,rho2,rho1_velocity\n1,0.7,0.7,0\n", "both columns rho1_velocity and rho2_velocity"),
    ("points:\n  - {time: 1.0, positions: [0.7, 0.7]}\ngoal_tolerance: {rho1: 0.001, rho3: 0.1}\n",
     "goal_tolerance.rho3: unknown key 'rho3'"),
])
def test_bad_trajectory_files_are_one_error_line(tmp_path, text, words):
    f = tmp_path / ("bad.yaml" if text.startswith("points") else "bad.csv")
    f.write_text(text)
    out = run_cli_here("follow", str(f))
    assert out.returncode == 2 and words in out.stderr and len(out.stderr.strip().splitlines()) == 1


def test_no_controller_exits_3():
    out = run_cli("move", "1.4", "0.7", "--timeout", "1", "--ros-args", "-r", "__ns:=/nobody_here")
    assert out.returncode == 3 and "not available" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr        # no progress bar before the error


def test_the_ik_node_takes_the_mechanism_from_the_scene(tmp_path, cli):
    """A scene with L = 1.3, k2 = 2: the IK node's answer is the core's for those parameters
    (it has no L or k parameters of its own any more)."""
    from tensegrity_core.sim import scene_path

    data = yaml.safe_load(scene_path("class2_at_rest").read_text())
    data["model"]["params"] = {"L": 1.3, "k1": 1.0, "k2": 2.0, "k3": 1.0, "k4": 1.0, "c": 0.01, "m": 2.0}
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(data))
    ik = cli("node", "ik", "--ros-args", "-r", "__ns:=/ik_scene", "-p", f"scene:={scene}", log_name="ik")
    ik.wait_for("solve_ik ready")
    params = Class2Params(L=1.3, k2=2.0)
    d = forward_kinematics(0.8, 0.9, params)
    out = run_cli_here("call-ik", f"{d.x!r}", f"{d.y!r}", "--json", "--ros-args", "-r", "__ns:=/ik_scene")
    assert out.returncode == 0, out.stderr
    sol = json.loads(out.stdout)["solutions"][0]
    core = inverse_kinematics(d.x, d.y, params).valid[0]
    assert (sol["rho1"], sol["rho2"]) == pytest.approx((core.rho1, core.rho2), abs=1e-12)
    assert (sol["rho1"], sol["rho2"]) == pytest.approx((0.8, 0.9), abs=1e-9)


# The suite's tests come last: its simulator and controller run their 100 Hz loop at real time
# (CPU all along) from its first test to the module's end, so no test without it runs inside.
@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from tests.ros_support import Proc

    folder = tmp_path_factory.mktemp("ctl_cli")
    # lockstep at 100 Hz (the controller's rate), paced at real time: the loop is the
    # sampled-data one whatever the load (tests/ros/test_controller_node.py)
    sim = Proc(["node", "sim", *NS, "-p", "lockstep:=true", "-p", "lockstep_real_time_factor:=1.0",
                "-p", "initial_state:=paused", "-p", "lockstep_timeout:=30.0"], folder / "sim.log")
    ctl = Proc(["node", "controller", *NS, "-p", "state_timeout:=2.0"], folder / "ctl.log")
    sim.wait_for("publishing at")
    ctl.wait_for("holding rho")
    played = run_cli_here("sim", "play", *NS)
    assert played.returncode == 0, played.stdout + played.stderr
    yield folder
    for p in (sim, ctl):
        p.stop()


def test_move_prints_the_result_and_exits_0(suite):
    d = forward_kinematics(0.7, 0.7)
    out = run_cli_here("move", f"{d.x + 0.02}", f"{d.y}", "--duration", "1.5", "--tolerance", "1e-4", "--json", *NS)
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    assert res["status"] == "SUCCESSFUL" and res["settled_error"] < 1e-4
    assert math.hypot(res["end_effector"]["x"] - d.x - 0.02, res["end_effector"]["y"] - d.y) < 1e-4


def test_move_outside_the_workspace_fails_with_the_reason(suite):
    out = run_cli_here("move", "3", "0.5", *NS)
    assert out.returncode == 1
    assert "failed (OUTSIDE_WORKSPACE)" in out.stdout and "not reachable" in out.stdout
    assert "Traceback" not in out.stderr


def test_follow_a_csv_file_shows_progress_and_succeeds(suite, tmp_path):
    d = forward_kinematics(0.7, 0.7)
    back = run_cli_here("move", f"{d.x}", f"{d.y}", "--duration", "1.5", *NS)       # from a known place
    assert back.returncode == 0, back.stdout + back.stderr
    f = tmp_path / "traj.csv"
    f.write_text("time,rho1,rho2\n1.0,0.705,0.7\n2.0,0.71,0.7\n")
    out = run_cli_here("follow", str(f), "--goal-tolerance", "1e-3", "--goal-time-tolerance", "8", *NS)
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.startswith("succeeded")
    assert "2.00/2.0 s" in out.stderr                    # the progress bar over the trajectory's time


def test_follow_yaml_with_a_bad_point_fails_with_the_controllers_reason(suite, tmp_path):
    f = tmp_path / "traj.yaml"
    # A well-formed file whose second point only the controller can judge: rho1 = 5 m is far
    # outside the mechanism's domain (rho1 < L = 1 m), which the file reader does not know.
    f.write_text(yaml.safe_dump({"points": [{"time": 0.5, "positions": [0.7, 0.7]},
                                            {"time": 1.0, "positions": [5.0, 0.7]}]}))
    out = run_cli_here("follow", str(f), *NS)
    assert out.returncode == 1 and "failed (INVALID_GOAL)" in out.stdout, (out.stdout, out.stderr)
    assert "outside the mechanism's domain" in out.stdout, out.stdout
