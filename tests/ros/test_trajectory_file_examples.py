"""The examples in tensegrity_ros/trajectory_file.py's docstring, read by the module itself
and followed by the core's sampled loop (the tracking law on the scene simulator, as the
controller runs it), meet their goal tolerance within their goal time with at least 1 s
to spare (a loaded machine's ROS run is not the core's exact loop)."""

from __future__ import annotations

import re
import textwrap

import pytest
import yaml

from studies.closed_loop import at_rest_scene
from tensegrity_core.class2 import PAPER_PARAMS
from tensegrity_core.class2.control import TrackingController
from tensegrity_core.class2.control import goals as G
from tensegrity_core.class2.control.trajectory import actuator_reference
from tensegrity_core.sim import Simulator
from tensegrity_ros import trajectory_file
from tests.class2.goal_loop import follow_to_outcome

DT = 0.01
MARGIN_S = 1.0


def _examples() -> dict[str, str]:
    """The docstring's literal blocks (after ``::``), by the file suffix their form needs."""
    blocks = re.findall(r"::\n\n((?:    .*\n|\n)+)", trajectory_file.__doc__)
    texts = [textwrap.dedent(b).strip() + "\n" for b in blocks]
    return {"csv" if t.startswith("time,") else "yaml": t for t in texts}


@pytest.mark.slow
@pytest.mark.parametrize("suffix", ["csv", "yaml"])
def test_the_docstring_example_meets_its_goal_time_with_margin(suffix, tmp_path):
    path = tmp_path / f"example.{suffix}"
    path.write_text(_examples()[suffix])
    traj = trajectory_file.read_trajectory(path)
    sim = Simulator(yaml.safe_dump(at_rest_scene(0.7, 0.7, PAPER_PARAMS)))
    ctrl = TrackingController(PAPER_PARAMS, dt=DT)
    ctrl.hold(0.7, 0.7)
    s = sim.joint_sample()
    ref = actuator_reference(traj.joint_names, traj.times, traj.positions, traj.velocities or None,
                             traj.accelerations or None, start_rho=s.q[:2], start_rate=s.qdot[:2],
                             params=PAPER_PARAMS)
    ctrl.follow(ref, 0.0)
    goal_time = traj.goal_time_tolerance or G.GOAL_TIME_TOLERANCE          # 0: the controller's default
    tol = tuple(traj.goal_tolerance.get(n, 1e-4) for n in ("rho1", "rho2"))
    goal = G.TrajectoryGoal(ref, 0.0, goal_position=tol, goal_time=goal_time - MARGIN_S)
    follow_to_outcome(sim, ctrl, goal, DT)
    assert goal.outcome.succeeded, goal.outcome.message
