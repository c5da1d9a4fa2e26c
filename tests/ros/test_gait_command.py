"""``tensegrity gait`` against the real suite (``tensegrity up --scene six_bar_rest``: the
simulator and the cable controller over DDS on loopback): one line and exit 3 when no suite
is up, one line and exit 1 for another robot's gait, and the 6-bar's first face rolled
through FollowJointTrajectory with the distance [m], faces and tensions [N] printed, and
whether the robot came to rest after the goal.

The ``gait`` commands run in this process (:func:`~tests.ros_support.run_cli_here`: what a
command says and returns, its ROS client over DDS as in a process of its own): a process of
its own cost an interpreter start and its imports (~1.5-2.6 s of CPU), during which the
suite's paced loop ran on for nobody. ``tests/ros/test_gait_closed_loop.py`` runs the
command as a process (a roll, and a refusal before any ROS)."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

from tests.ros_support import run_cli_here

pytestmark = [pytest.mark.ros, pytest.mark.slow]

NS = "/gait_test"
#: m: a tip over an edge of a closed face carries the centre of mass from 0.300 m inside
#: the edge (the triangle's inradius less the sag, docs/robots.md) to beyond it.
CLOSED_FACE_MARGIN = 0.30
#: The suite's lockstep loop paced at real time: unpaced, a playing lockstep simulator and
#: its cable controller step as fast as they can from the suite's start to the test's end,
#: most of it while the test's clients start (~25 s of CPU a test beside two busy
#: processes); paced, no step is lost either (a late answer slows the clock), and a gait
#: of a few seconds of simulation time takes those seconds.
PACED = ("-p", "lockstep_real_time_factor:=1.0")


def test_gait_says_when_no_suite_is_up_and_rolls_the_six_bar(cli, tmp_path):
    r = run_cli_here("gait", "six_bar", "six_bar_roll", "--faces", "1", "-n", NS, "--timeout", "1")
    assert r.returncode == 3, r.stdout + r.stderr
    assert r.stderr.strip().splitlines() == [f"error: no simulator answers in namespace {NS} after 1 s (is the suite "
                                             "up? `tensegrity up --scene six_bar_rest`)"]

    # in lockstep: the cable controller answers every state, so no step is lost on a loaded
    # machine; paced at real time (PACED), the loop does not burn both cores on steps nobody
    # watches while the test starts its clients
    up = cli("up", "--scene", "six_bar_rest", "--no-formfind", "--namespace", NS, "--ros-args", "-p",
             "lockstep:=true", *PACED, log_name="up")
    deadline = time.monotonic() + 120                  # a guard against a hang, not a timing
    while "cable controller ready" not in _stdout_so_far(up):
        assert up.popen.poll() is None and time.monotonic() < deadline, _stdout_so_far(up)
        time.sleep(0.2)

    r = run_cli_here("gait", "three_bar", "three_bar_crawl", "-n", NS, "--timeout", "30")
    assert r.returncode == 1, r.stdout + r.stderr
    assert r.stderr.strip().splitlines() == ["error: the running suite simulates the robot six_bar (scene "
                                             "'six_bar_rest'), not three_bar"]

    r = run_cli_here("gait", "six_bar", "six_bar_roll", "--faces", "1", "-n", NS, "--timeout", "30", "--settle", "0")
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.startswith("succeeded:"), r.stdout
    distance = float(re.search(r"distance rolled: (\S+) m", r.stdout).group(1))
    assert distance > CLOSED_FACE_MARGIN, r.stdout
    assert re.search(r"faces rolled: \d+ \(\d+ faces rested on\)", r.stdout), r.stdout
    tensions = [float(v) for v in re.findall(r"c\d+_\d+ (\S+) N", r.stdout)]
    assert len(tensions) == 3 and all(t > 0 for t in tensions), r.stdout
    # said whether the robot is at rest at the goal's end, or how fast it still moves (--settle 0:
    # no watch after the goal, which keeps this lockstep run as short as the gait)
    assert re.search(r"^  (at rest on a face \d+\.\d\d s after the goal's end|still moving 0 s after the goal's "
                     r"end \(centre at \d+\.\d\d m/s\): the distance and faces above are those up to then)$",
                     r.stdout, re.M), r.stdout


def _stdout_so_far(proc) -> str:
    """What ``tensegrity up`` printed so far (its children's lines go to its stdout)."""
    import os
    import select

    out = proc.popen.stdout
    chunks = getattr(proc, "_seen", "")
    while select.select([out], [], [], 0)[0]:
        data = os.read(out.fileno(), 65536).decode(errors="replace")
        if not data:
            break
        chunks += data
    proc._seen = chunks
    return chunks


def test_a_gait_waits_for_slow_motors_to_arrive(cli):
    """The 3-bar's motors lag by 1 s (no slew limit): its crawl ends with its rest lengths
    about 0.07 m short of the last point's, which they close to the controller's goal tolerance
    (0.1 mm) in about ln(0.07 / 1e-4) = 6.5 s, past the controller's goal_time_tolerance of 1 s.
    The gait's goal (a joint_trajectory_controller client's: the default goal time) gets those
    1 s plus the motors' bound, 1 ln(0.6 / 1e-4) = 8.7 s (their 0.6 m range), so it succeeds
    once they are there."""
    ns = NS + "_three_bar"
    up = cli("up", "--scene", "three_bar_drop", "--no-formfind", "--namespace", ns, "--ros-args", "-p",
             "lockstep:=true", *PACED, log_name="up_three_bar")
    deadline = time.monotonic() + 120                  # a guard against a hang, not a timing
    while "cable controller ready" not in _stdout_so_far(up):
        assert up.popen.poll() is None and time.monotonic() < deadline, _stdout_so_far(up)
        time.sleep(0.2)
    r = run_cli_here("gait", "three_bar", "three_bar_crawl", "--repeats", "1", "-n", ns, "--timeout", "30",
                     "--settle", "0")
    assert r.returncode == 0, r.stdout + r.stderr
    after = float(re.match(r"succeeded: within the goal tolerance (\S+) s after the end", r.stdout).group(1))
    assert 1.0 < after < 1.0 + np.log(0.6 / 1e-4), r.stdout
