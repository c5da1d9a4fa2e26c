"""What a careless user types at the ROS commands' edges: malformed ``--ros-args``, names ROS
would not take (topics, services, actions, namespaces), times and counts out of range, a
node parameter out of its range, a scene or a plot path that is not there. Each is one ``error:`` line naming the option and
what it accepts, exit code 2, before any node is created (never a traceback, never a wait).

Commands that keep the process's signal handling (``node``, ``up``, ``record``, ``play``) run
as processes (forked from one interpreter that imported once: :mod:`tests.forked_cli`), the
others in this process through the CLI's ``main``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_ros.cli import main
from tests.forked_cli import run_all

pytestmark = pytest.mark.ros

FOLD = str(Path(__file__).resolve().parents[2] / "bags" / "fold")

IN_PROCESS = [   # (arguments, words the error line must hold)
    (["sim", "step", str(2**64)], "steps must be a whole number in [1, 18446744073709551615]"),
    (["sim", "state", "--timeout", "nan"], "--timeout must be a finite number of seconds > 0, got nan"),
    (["call-ik", "1.4", "0.7", "--timeout", "-1"], "--timeout must be a finite number of seconds > 0"),
    (["call-formfind", "tensegrity_table", "--max-iter", "-1"], "--max-iter must be a whole number in [0, 4294967295]"),
    (["call-formfind", "tensegrity_table", "--max-iter", str(2**32)], "--max-iter"),
    (["call-formfind", "tensegrity_table", "--tol", "nan"], "--tol must be a finite relative residual >= 0"),
    (["echo", "joint_states", "--count", "-3"], "--count must be a whole number in [0, "),
    (["echo", "joint_states", "--timeout", "nan"], "--timeout must be a finite number of seconds >= 0 (0 = never)"),
    (["move", "1.4", "0.7", "--timeout", "0"], "--timeout must be a finite number of seconds > 0, got 0"),
    (["follow", "no_such_file.csv", "--timeout", "inf"], "--timeout"),
    (["follow", "trajectory.csv", "--goal-time-tolerance", "1e12"],       # Duration's int32 seconds wrapped
     "the goal time tolerance must be a finite number of seconds in [0, 1e9)"),
    (["send-forces", "1", "0", "--topic", "bad topic"], "--topic 'bad topic' is not a valid ROS name"),
    (["echo", "bad topic"], "topic 'bad topic' is not a valid ROS name"),
    (["call-ik", "1.4", "0.7", "--service", "bad srv"], "--service 'bad srv' is not a valid ROS name"),
    (["move", "1.4", "0.7", "--action", "a b"], "--action 'a b' is not a valid ROS name"),
    (["gait", "six_bar", "six_bar_roll", "-n", "bad ns"], "--namespace 'bad ns' is not a valid ROS namespace"),
    (["call-ik", "1.4", "0.7", "--ros-args", "-p", "x"], "parameter override rule: '-p x' (expected -p NAME:=VALUE)"),
    (["bag", "plot", FOLD, "-o", "no_such_folder/fold.png"], "folder 'no_such_folder' does not exist"),
]

AS_PROCESSES = [
    (["node", "ik", "--ros-args", "-p", "paper_range"], "(expected -p NAME:=VALUE)"),
    (["node", "sim", "--ros-args", "-r", "__ns:=relative"], "remap rule: '-r __ns:=relative'"),
    (["node", "sim", "--ros-args", "--bogus"], "unknown ROS arguments: --bogus"),
    (["up", "--namespace", "bad ns"], "--namespace 'bad ns' is not a valid ROS namespace"),
    (["up", "--params-file", "no_such_params.yaml"], "params file: '--params-file no_such_params.yaml'"),
    (["record", "-o", "bag", "bad topic"], "topic 'bad topic' is not a valid ROS name"),
    (["play", FOLD, "--topics", "bad topic"], "--topics 'bad topic' is not a valid ROS name"),
    (["play", FOLD, "--wait-for-all-acked", "nan"],
     "--wait-for-all-acked must be a finite number of seconds >= 0 (0 = exit at once), got nan"),
    (["play", FOLD, "--resimulate", "--scene", "no_such_scene"], "cannot load the scene to re-simulate on: 'no_such_scene'"),
    # node parameters, checked as the node starts: the range and the unit
    (["node", "sim", "--ros-args", "-p", "publish_rate:=-5"],
     "tensegrity_sim: parameter publish_rate must be a finite number in [1, 1000] Hz, got -5 Hz"),
    (["node", "sim", "--ros-args", "-p", "safe_force:=2000"],
     "parameter safe_force must be in [-max_force, max_force] = [-1000, 1000] N, got 2000 N"),
    # frame names tf2 would refuse to look up (tf2's validateFrameId): empty, or starting with '/'
    (["node", "sim", "--ros-args", "-p", "frame_prefix:=/robot1/"],
     "tensegrity_sim: parameter frame_prefix must not start with '/' (tf2 refuses such frame ids: "
     "write 'robot1/'), got '/robot1/'"),
    (["node", "sim", "--ros-args", "-p", "frame_id:=/world"],
     "tensegrity_sim: parameter frame_id must not start with '/' (tf2 refuses such frame ids: "
     "write 'world'), got '/world'"),
    (["node", "sim", "--ros-args", "-p", "frame_id:=''"],
     "tensegrity_sim: parameter frame_id must name a frame (tf2 refuses an empty frame id), got ''"),
    # a robot (bot_drop.yaml, written by _write_bot) whose IMU's body '1-rod a' names no ROS topic:
    # the core takes any name, and rclpy's InvalidTopicNameException ended the simulator in a traceback
    (["node", "sim", "--ros-args", "-p", "scene:=bot_drop.yaml"],
     "error: tensegrity_sim: the IMU of '1-rod a' cannot publish on 'imu/1-rod a': a ROS topic name holds "
     "letters, digits and '_' in tokens that do not start with a digit; rename the body in the robot's "
     "description"),
    (["node", "controller", "--ros-args", "-p", "state_timeout:=0.0"],
     "error: tensegrity_controller: parameter state_timeout must be a finite number >= 0.01 s, got 0 s"),
    (["node", "formfind", "--ros-args", "-p", "max_workers:=0"],
     "tensegrity_formfind: parameter max_workers must be a whole number in [1, 64] processes, got 0"),
    (["node", "formfind", "--ros-args", "-p", "time_limit:=abc"],
     "tensegrity_formfind: parameter time_limit must be a number [s], got 'abc'"),
    # a value of another type than the parameter's, for every node: the type in words, the range, the unit
    (["node", "ik", "--ros-args", "-p", "paper_range:=maybe"],
     "error: tensegrity_ik: parameter paper_range must be true or false, got 'maybe' (text)"),
    (["node", "sim", "--ros-args", "-p", "lockstep:=1"],
     "error: tensegrity_sim: parameter lockstep must be true or false, got '1' (a whole number)"),
    (["node", "controller", "--ros-args", "-p", "scene:=[1, 2]"],
     "error: tensegrity_controller: parameter scene must be text, got '[1, 2]' (a list of whole numbers)"),
    (["node", "cables", "--ros-args", "-p", "scene:=true"],
     "error: tensegrity_cable_controller: parameter scene must be text, got 'True' (a boolean)"),
    (["node", "formfind", "--ros-args", "-p", "max_workers:=two"],
     "error: tensegrity_formfind: parameter max_workers must be a whole number in [1, 64] processes, got 'two' (text)"),
    (["node", "formfind", "--ros-args", "-p", "max_members:=1.5"],
     "error: tensegrity_formfind: parameter max_members must be a whole number in [1, 2147483647] members, "
     "got '1.5' (a number)"),
]


def _one_error_line(stderr: str) -> str:
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), stderr
    return lines[0]


@pytest.mark.parametrize("args, words", IN_PROCESS, ids=[" ".join(a[:2]) for a, _ in IN_PROCESS])
def test_a_bad_option_of_a_client_command_is_one_line_and_exit_2(args, words, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "trajectory.csv").write_text("time,rho1,rho2\n1.0,0.705,0.7\n2.0,0.71,0.7\n")
    assert main(args) == 2
    out = capsys.readouterr()
    assert words in _one_error_line(out.err) and out.out == ""


@pytest.mark.parametrize("name, text, words", [
    ("back.csv", "time,rho1,rho2\n1,0.7,0.7\n2,0.71,0.7\n1.5,0.7,0.7\n",
     "back.csv: time: point 2 at 1.5 s does not follow point 1 at 2 s (times must increase strictly) (line 4)"),
    ("same.yaml", "points:\n  - {time: 1.0, positions: [0.7, 0.7]}\n  - {time: 1.0, positions: [0.7, 0.7]}\n",
     "same.yaml: points[1].time: point 1 at 1 s does not follow point 0 at 1 s"),
    ("early.csv", "time,rho1,rho2\n-1e-12,0.7,0.7\n", "early.csv: time: point 0: time -1e-12 s is negative"),
])
def test_a_trajectory_whose_times_do_not_increase_is_refused_as_the_file_is_read(name, text, words, capsys,
                                                                                  tmp_path, monkeypatch):
    """The reader refuses it, naming the point and its line (exit 2), before any node is made:
    no controller runs here, so a file that got past the reader would time out (exit 3)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / name).write_text(text)
    assert main(["follow", name, "--timeout", "0.5"]) == 2
    out = capsys.readouterr()
    assert words in _one_error_line(out.err) and out.out == ""


def _write_bot(folder: Path) -> None:
    """The 3-bar with its rod r01 renamed '1-rod a' (its IMU too) and a scene dropping it, in ``folder``."""
    import yaml

    from tensegrity_core.robot.loading import robot_path

    robot = yaml.safe_load(robot_path("three_bar").read_text())
    for rod in robot["rods"]:
        rod["name"] = {"r01": "1-rod a"}.get(rod["name"], rod["name"])
    robot["sensors"]["imu"] = ["1-rod a", "r23"]
    (folder / "bot.yaml").write_text(yaml.safe_dump(robot))
    (folder / "bot_drop.yaml").write_text(yaml.safe_dump({
        "name": "bot_drop", "model": {"kind": "robot", "robot": str(folder / "bot.yaml")},
        "initial": {"drawn": True, "lift": 0.05}, "duration": 1.0,
        "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"]}))


def test_a_bad_argument_of_a_long_running_command_is_one_line_and_exit_2(tmp_path):
    _write_bot(tmp_path)
    for done, (args, words) in zip(run_all([a for a, _ in AS_PROCESSES], tmp_path), AS_PROCESSES):
        assert done.returncode == 2, (args, done.stdout, done.stderr)
        assert words in _one_error_line(done.stderr), args
    assert not (tmp_path / "bag").exists()                      # refused before anything was made


@given(st.lists(st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
                        max_size=12), max_size=4))
def test_any_ros_arguments_are_taken_or_refused_in_one_line(words):
    """Whatever follows ``--ros-args``: rcl takes it, or it is one line naming what it could
    not parse (a CliError), never another exception. (A NUL cannot be in a process argument.)"""
    from tensegrity_ros.cli._common import CliError
    from tensegrity_ros.cli.ros_clients import check_ros_args

    try:
        check_ros_args(["--ros-args", *words])
    except CliError as err:
        assert "\n" not in str(err) and str(err)


@given(st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=20),
       st.booleans())
def test_any_name_is_taken_or_refused_in_one_line(name, namespace):
    from tensegrity_ros.cli._common import CliError
    from tensegrity_ros.cli.ros_clients import check_ros_name

    try:
        check_ros_name(name, "--topic", namespace=namespace)
    except CliError as err:
        assert "\n" not in str(err) and "not a valid ROS" in str(err)


def test_up_stops_the_suite_when_its_simulator_refuses_its_parameters(tmp_path):
    """The simulator exits 2 at once; the cable controller beside it is stopped (the suite
    would otherwise sit there without a simulator) and `up` exits with the simulator's code."""
    import subprocess

    from tests.ros_support import TENSEGRITY

    done = subprocess.run([TENSEGRITY, "up", "--scene", "table_actuated", "--no-formfind", "-n", "/up_refused",
                           "--ros-args", "-p", "publish_rate:=-5"],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    said = done.stdout + done.stderr
    assert done.returncode == 2, said
    assert "[launch] sim exited with code 2: stopping the suite" in done.stdout, said
    assert ("[sim] error: tensegrity_sim: parameter publish_rate must be a finite number in [1, 1000] Hz, got -5 Hz"
            in done.stdout), said
    assert "Traceback" not in said
