"""``tensegrity gait six_bar roll --faces N``, the closed-loop rolling gait, against the real
suite over DDS on loopback: bad requests are one line before any ROS; in lockstep (the suite
without its cable controller: the gait answers every state) the 6-bar rolls exactly the
faces asked (2, then 1 more from where it rests), counted from the simulator's ``contacts`` by the summary
(faces rested on, :func:`tensegrity_core.robot.faces.faces_visited`, and hull faces touched
however briefly, :func:`~tensegrity_core.robot.faces.faces_touched`), not by the controller, and comes to rest
there; then the suite's cable controller is started beside it (a second answerer of the lockstep
simulator's states) and the gait is refused in one line naming it.

Lockstep keeps each run as short as the robot's motion (2 faces: ~4 s of simulation time,
~450 steps of 10 ms) on a busy machine, where free-running would take that in wall time. The
three runs share one suite (its start-up is the largest part): ~20-30 s in all under load,
less than three tests each starting a suite."""

from __future__ import annotations

import re

import pytest

from tests.ros_support import Proc, run_cli, run_cli_here

pytestmark = [pytest.mark.ros, pytest.mark.slow]

NS = "/gait_loop_test"
#: m: a tip over an edge of a closed face carries the centre of mass from 0.300 m inside
#: the edge (the triangle's inradius less the sag, docs/robots.md) to beyond it.
CLOSED_FACE_MARGIN = 0.30


@pytest.mark.parametrize(("args", "line"), [
    (("three_bar", 1, None, None, None), "the closed-loop roll needs a table of tipping moves, shipped for: six_bar "
                                         "(not three_bar)"),
    (("six_bar", None, None, None, None), "roll needs --faces N, the faces to roll (N >= 1)"),
    (("six_bar", 0, None, None, None), "roll needs --faces N, the faces to roll (N >= 1), got 0"),
    (("six_bar", 1, [0.0, 0.0], None, None), "--heading must be a nonzero direction X Y on the floor, got 0 0"),
    (("six_bar", 1, [float("nan"), 1.0], None, None), "--heading must be a nonzero direction X Y on the floor, "
                                                      "got nan 1"),
    (("six_bar", 1, None, -1.0, None), "--max-time must be > 0 s and at most 86400 s (a day of simulation time), "
                                       "got -1.0"),
    (("six_bar", 1, None, 86401.0, None), "--max-time must be > 0 s and at most 86400 s (a day of simulation "
                                          "time), got 86401.0"),
    # a day of simulation time at 10 s a face: 86400 / 10 = 8640 faces
    (("six_bar", 10**9, None, None, None), "--faces must be at most 8640 (10 s of simulation time a face within a "
                                           "roll's 86400 s, a day), got 1000000000"),
    (("six_bar", 8641, None, 10.0, None), "--faces must be at most 8640 (10 s of simulation time a face within a "
                                          "roll's 86400 s, a day), got 8641"),
    (("six_bar", 1, None, None, 2), "--repeats is for periodic gaits, not roll"),
])
def test_bad_requests_are_one_line(args, line):
    from tensegrity_ros.cli._common import CliError
    from tensegrity_ros.cli.cmd_gait import check_roll

    with pytest.raises(CliError) as err:
        check_roll(*args)
    assert str(err.value) == line and err.value.code == 2


def test_the_largest_roll_is_taken():
    from tensegrity_ros.cli.cmd_gait import check_roll

    assert check_roll("six_bar", 8640, None, None, None) == (8640, (1.0, 0.0), 86400.0)
    assert check_roll("six_bar", 1, None, 86400.0, None)[2] == 86400.0


def test_a_bad_request_is_one_line_before_any_ros():
    r = run_cli("gait", "six_bar", "six_bar_roll", "--heading", "1", "0")
    assert r.returncode == 2, r.stdout + r.stderr          # a usage error
    assert r.stderr.strip().splitlines() == ["error: --heading and --max-time are for the closed-loop roll, not a "
                                             "gait table"]


def test_the_closed_loop_gait_rolls_exactly_the_faces_asked_in_lockstep(cli, tmp_path):
    up = cli("up", "--scene", "six_bar_rest", "--no-formfind", "--no-controller", "--namespace", NS, "--ros-args",
             "-p", "lockstep:=true", log_name="up")
    # this run as a process of its own (its exit after a roll too); the later ones in this process: no
    # interpreter start and imports (~1.5-2.6 s of CPU each), their ROS clients over DDS the same
    r = run_cli("gait", "six_bar", "roll", "--faces", "2", "-n", NS, "--timeout", "60", timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr + up.stderr()
    assert re.match(r"done: the controller rolled 2 of 2 faces towards \(\+1\.00, \+0\.00\) in \d+\.\d\d s of "
                    r"simulation time \(50 Hz closed loop\)\n", r.stdout), r.stdout
    assert re.search(r"^  faces rolled: 2 \(\d+ faces rested on; 2 faces crossed, counting those touched however "
                     r"briefly\)$", r.stdout, re.M), r.stdout
    distance = float(re.search(r"distance rolled: (\S+) m", r.stdout).group(1))
    assert distance > CLOSED_FACE_MARGIN, r.stdout               # past the first edge at least
    dx = float(re.search(r"centre moved by \((\S+),", r.stdout).group(1))
    assert dx > 0, r.stdout                                       # towards the heading +x
    # whether the robot is at rest after the controller's end, or how fast it still rocks on its face
    assert re.search(r"^  (at rest on a face \d+\.\d\d s after the controller released the motors|still moving 2 s "
                     r"after the controller released the motors \(centre at 0\.0\d m/s\): the distance and faces "
                     r"above are those up to then)$", r.stdout, re.M), r.stdout

    # one face more, from the face it rests on now: exactly one
    r = run_cli_here("gait", "six_bar", "roll", "--faces", "1", "-n", NS, "--timeout", "60")
    assert r.returncode == 0, r.stdout + r.stderr + up.stderr()
    assert r.stdout.startswith("done: the controller rolled 1 of 1 faces"), r.stdout
    assert re.search(r"^  faces rolled: 1 \(\d+ faces rested on; 1 faces crossed, counting those touched however "
                     r"briefly\)$", r.stdout, re.M), r.stdout

    # the suite's cable controller started beside the gait's lockstep suite: two answers to a
    # state; refused in one line naming it, whether the gait finds it in the graph before it
    # starts or hears its answers once it runs. The simulator is paused first: playing, it would
    # step as fast as the controller answers while the gait starts (~25 s of CPU of the two
    # beside busy processes); paused, it republishes its state (paused_publish_rate, 1 Hz),
    # which the controller answers, in the graph the same
    paused = run_cli_here("sim", "pause", "--ros-args", "-r", f"__ns:={NS}")
    assert paused.returncode == 0, paused.stdout + paused.stderr
    controller = Proc(["node", "cables", "--ros-args", "-r", f"__ns:={NS}", "-p", "scene:=six_bar_rest"],
                      tmp_path / "cables.log")
    try:
        controller.wait_for("cable controller ready", 60)
        r = run_cli_here("gait", "six_bar", "roll", "--faces", "1", "-n", NS, "--timeout", "60")
    finally:
        controller.stop()
    assert r.returncode == 1, r.stdout + r.stderr + controller.stderr()
    assert r.stderr.strip().splitlines()[-1] == (
        f"error: the simulator runs in lockstep and {NS}/tensegrity_cable_controller already answers its states on "
        "cable_commands: the closed-loop gait must be the only one (start the suite with "
        "`tensegrity up --no-controller`)"), r.stderr

