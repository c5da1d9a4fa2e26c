"""The tracking law in a sampled-data loop with the scene simulator (issue 15's targets).

The loop is the real one: the law evaluated at t_k on the simulator's state, its output
held for one period (``Simulator.set_command``, ``advance``). The numbers checked are the
issue's: D within 0.05 mm of each demo waypoint 2 s after the move, no force over the
limit; an unmodelled constant load on D settles with no error only thanks to the integral.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from studies.closed_loop import at_rest_scene, circle_study, waypoint_study
from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics
from tensegrity_core.class2.control import LQRWeights, TrackingController, plan_move
from tensegrity_core.class2.control import goals as G
from tensegrity_core.class2.control.trajectory import actuator_reference
from tensegrity_core.sim import Simulator
from tests.class2.goal_loop import follow_to_outcome

P = PAPER_PARAMS
D0 = forward_kinematics(0.7, 0.7, P)
DT = 0.01


def run(sim: Simulator, ctrl: TrackingController, t_end: float) -> list:
    """The sampled loop until ``t_end``; returns (t, D, forces) per tick."""
    out = []
    while sim.t < t_end - 1e-9:
        s = sim.joint_sample()
        tick = ctrl.update(s.t, s.q, s.qdot)
        out.append((s.t, s.end_effector[:2].copy(), tick.forces))
        sim.set_command(list(tick.forces))
        sim.advance(round(s.t / DT + 1) * DT)
    return out


def error_to(sim: Simulator, target) -> float:
    s = sim.joint_sample()
    return math.hypot(s.end_effector[0] - target[0], s.end_effector[1] - target[1])


@pytest.mark.slow
def test_demo_waypoints_settle_below_0p05_mm_within_2_s_without_exceeding_the_force_limit():
    result = waypoint_study("lqr", move_time=2.0, settle_time=2.0, rate=100.0, max_force=5.0)
    assert len(result.moves) == 4
    for move in result.moves:
        assert move.settled_error < 5e-5, move
        assert move.settling_time <= 2.0, move
        assert move.max_force <= 5.0
    forces = np.asarray(result.trace.forces)
    assert np.all(np.abs(forces) <= 5.0)


@pytest.mark.slow
def test_circle_is_traced_within_ten_micrometres():
    result = circle_study("lqr", radius=0.05, period=4.0, ramp=2.0, rate=100.0)
    assert result.extra["max_error"] < 1e-5          # the issue: 5 cm radius, 4 s per turn
    assert result.extra["max_force"] <= 5.0


def _load_scene(load):
    scene = at_rest_scene(0.7, 0.7, P)
    scene["effects"].append({"loads": {"D": [load[0], load[1], 0.0]}})
    return yaml.safe_dump(scene)


@pytest.mark.parametrize("integral, settles", [(LQRWeights().integral, True), (1e6, False)])
def test_integral_action_removes_the_error_of_an_unmodelled_load(integral, settles):
    """A 10 mN load on D that the controller does not know: with the integral of D's error
    D returns to the held point; without it (weight scale 1e6: no integral) it stays off by
    what the proportional stiffness allows (~ load / stiffness, millimetres here)."""
    sim = Simulator(_load_scene((0.01, -0.01)))
    ctrl = TrackingController(P, dt=DT, weights=LQRWeights(integral=integral))
    ctrl.hold(0.7, 0.7)
    run(sim, ctrl, 12.0)
    err = error_to(sim, (D0.x, D0.y))
    if settles:
        assert err < 5e-6
    else:
        assert err > 1e-4


def test_force_limit_is_respected_and_the_integral_does_not_wind_up():
    """The mechanism starts 5 cm (in rho1) from the held rest with a 2 N limit: the
    feedback wants more, the output stays within the limit, the integral is frozen while
    saturated (anti-windup) and bounded, and D still settles on the held point."""
    limit = 2.0
    sim = Simulator(yaml.safe_dump(at_rest_scene(0.75, 0.7, P)))
    ctrl = TrackingController(P, dt=DT, max_force=limit)
    ctrl.hold(0.7, 0.7)
    target = (D0.x, D0.y)
    ticks = run(sim, ctrl, 10.0)
    forces = np.array([f for _, _, f in ticks])
    assert np.all(np.abs(forces) <= limit)
    assert np.mean(np.any(np.abs(forces) >= limit - 1e-12, axis=1)) > 0.01     # it did saturate
    assert np.max(np.abs(ctrl.gains.at(10.0)[:, 6:] @ ctrl.z)) <= limit + 1e-12
    assert error_to(sim, target) < 5e-5


@pytest.mark.slow
def test_the_documented_actuator_trajectory_meets_the_default_goal_tolerance_in_the_default_time():
    """docs/control.md's trajectory, rho = (0.71, 0.69) m at 2 s, (0.72, 0.70) m at 4 s,
    (0.70, 0.70) m at 6 s, is quasi-static: the lengths come within the default goal
    tolerance (0.1 mm) more than 3 s after its last point (the earlier default goal time,
    which `tensegrity follow` then failed) and within the default goal time."""
    sim = Simulator(yaml.safe_dump(at_rest_scene(0.7, 0.7, P)))
    ctrl = TrackingController(P, dt=DT)
    ctrl.hold(0.7, 0.7)
    s = sim.joint_sample()
    ref = actuator_reference(["rho1", "rho2"], [2.0, 4.0, 6.0], [[0.71, 0.69], [0.72, 0.70], [0.70, 0.70]],
                             start_rho=s.q[:2], start_rate=s.qdot[:2], params=P)
    ctrl.follow(ref, 0.0)
    goal = G.TrajectoryGoal(ref, 0.0)                 # the defaults: 0.1 mm within GOAL_TIME_TOLERANCE
    s = follow_to_outcome(sim, ctrl, goal, DT)
    assert goal.outcome.succeeded, goal.outcome.message
    assert 3.0 < s.t - ref.duration <= G.GOAL_TIME_TOLERANCE


def test_a_new_goal_preempts_the_running_one_mid_move_and_cancel_holds_where_the_reference_is():
    sim = Simulator(yaml.safe_dump(at_rest_scene(0.7, 0.7, P)))
    ctrl = TrackingController(P, dt=DT)
    ctrl.hold(0.7, 0.7)
    ctrl.follow(plan_move(sim.joint_sample().q, (D0.x + 0.08, D0.y), P, duration=2.0), 0.0)
    run(sim, ctrl, 1.0)                               # half way
    second = (D0.x, D0.y + 0.05)
    ctrl.follow(plan_move(sim.joint_sample().q, second, P, duration=2.0), sim.t)
    run(sim, ctrl, 9.0)                               # the preempting move starts at rest: a transient
    assert error_to(sim, second) < 5e-5
    # a third move, cancelled half way: the controller holds the reference's configuration then
    ctrl.follow(plan_move(sim.joint_sample().q, (D0.x + 0.05, D0.y + 0.05), P, duration=2.0), sim.t)
    run(sim, ctrl, 10.0)
    ctrl.hold_here(sim.t)
    held = ctrl.reference.final().end_effector
    run(sim, ctrl, 16.0)
    assert error_to(sim, held) < 5e-5
    assert ctrl.reference.kind == "hold"
