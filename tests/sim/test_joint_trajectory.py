"""Trajectories of commanded inputs (joint_trajectory_controller's semantics) and the path and
goal checks of a goal.

Oracles: numpy's linear interpolation, the cubic Hermite basis written out here, the points'
own positions, velocities and accelerations at the knots, and hand-made tolerance cases.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.sim.joint_trajectory import (
    GOAL_TOLERANCE_VIOLATED,
    INVALID_GOAL,
    INVALID_JOINTS,
    PATH_TOLERANCE_VIOLATED,
    SUCCESSFUL,
    GoalMonitor,
    Tolerances,
    TrajectoryError,
    plan_trajectory,
    tolerance,
)
from tensegrity_core.sim.model import Interface

CABLES = Interface("rest_length", ("a", "b", "c"), (True, True, False), ((0.0, math.inf),) * 3, (0, 1, 2))
START = (0.9, 0.8, 0.7)


def times_and_values(n_max=6):
    steps = st.lists(st.floats(0.05, 2.0), min_size=1, max_size=n_max)
    return steps.flatmap(lambda d: st.tuples(st.just(np.cumsum(d)),
                                             st.lists(st.floats(0.2, 2.0), min_size=len(d), max_size=len(d))))


@given(times_and_values(), st.lists(st.floats(0.0, 1.0), min_size=5, max_size=5))
def test_positions_only_interpolate_linearly_from_the_start(tv, fractions):
    t, p = tv
    tr = plan_trajectory(["b"], t, [[v] for v in p], interface=CABLES, start=START)
    knots, values = np.concatenate([[0.0], t]), np.concatenate([[START[1]], p])
    for f in fractions:
        tau = f * t[-1]
        assert tr.sample(tau).positions[0] == pytest.approx(np.interp(tau, knots, values), abs=1e-12)
    assert tr.sample(t[-1] + 1.0).positions[0] == p[-1] and tr.sample(t[-1] + 1.0).velocities[0] == 0.0
    assert tr.sample(-1.0).positions[0] == START[1]


def test_velocities_give_cubic_hermite_segments_and_accelerations_quintic_ones():
    t = [0.0, 0.5, 1.5]
    p = [[0.9, 0.8], [0.85, 0.82], [0.95, 0.8]]
    v = [[0.0, 0.0], [0.1, -0.2], [0.0, 0.0]]
    tr = plan_trajectory(["a", "b"], t, p, v, interface=CABLES, start=START)
    h = 1.0
    for tau in np.linspace(0.5, 1.5, 7):
        s = (tau - 0.5) / h
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        expected = h00 * np.array(p[1]) + h10 * h * np.array(v[1]) + h01 * np.array(p[2]) + h11 * h * np.array(v[2])
        np.testing.assert_allclose(tr.sample(tau).positions, expected, atol=1e-12)
    a = [[0.0, 0.0], [1.0, -0.5], [0.0, 0.0]]
    quintic = plan_trajectory(["a", "b"], t, p, v, a, interface=CABLES, start=START)
    for k in range(2):
        s = quintic.sample(t[k] + 1e-12 if k else 0.0)
        np.testing.assert_allclose([s.positions, s.velocities, s.accelerations], [p[k], v[k], a[k]], atol=1e-9)


def test_a_command_sets_the_trajectorys_joints_and_holds_the_others():
    tr = plan_trajectory(["b"], [1.0], [[0.6]], interface=CABLES, start=START)
    assert tr.command(0.5, [0.9, 0.8, 0.7]) == pytest.approx([0.9, 0.7, 0.7])
    assert tr.command(2.0, [0.9, 0.8, 0.7]) == [0.9, 0.6, 0.7]
    held = plan_trajectory(["a"], [0.0], [[0.5]], interface=CABLES, start=START)
    assert held.duration < 1e-6 and held.command(3.0, START) == [0.5, 0.8, 0.7]


@pytest.mark.parametrize("names, times, positions, extra, code, reason", [
    (["z"], [1.0], [[0.5]], {}, INVALID_JOINTS, "unknown joint 'z'; the joints are a, b"),
    (["c"], [1.0], [[0.5]], {}, INVALID_JOINTS, "unknown joint 'c'"),            # follows a law
    (["a", "a"], [1.0], [[0.5, 0.5]], {}, INVALID_JOINTS, "named twice"),
    ([], [1.0], [[]], {}, INVALID_JOINTS, "names no joints"),
    (["a"], [], [], {}, INVALID_GOAL, "no points"),
    (["a"], [1.0, 1.0], [[0.5], [0.6]], {}, INVALID_GOAL, "must increase strictly"),
    (["a"], [-1.0], [[0.5]], {}, INVALID_GOAL, "finite and >= 0"),
    (["a"], [1.0], [[-0.5]], {}, INVALID_GOAL, "position of a = -0.5 m is outside its range"),
    (["a"], [1.0], [[math.nan]], {}, INVALID_GOAL, "not finite"),
    (["a"], [1.0], [[0.5, 0.6]], {}, INVALID_GOAL, "2 positions for the 1 joints"),
    (["a"], [1.0, 2.0], [[0.5], [0.6]], {"accelerations": [[0.0], [0.0]]}, INVALID_GOAL, "need velocities"),
    (["a"], [1.0, 2.0], [[0.5], [0.6]], {"velocities": [[0.0]]}, INVALID_GOAL, "1 rows for 2 points"),
    # joint_trajectory_controller's default (allow_nonzero_velocity_at_trajectory_end: false)
    (["b", "a"], [1.0, 2.0], [[0.5, 0.5], [0.6, 0.6]], {"velocities": [[0.1, 0.1], [0.0, -1e-3]]}, INVALID_GOAL,
     "last point's velocity of a is -0.001 m/s"),
])
def test_bad_trajectories_say_why(names, times, positions, extra, code, reason):
    with pytest.raises(TrajectoryError, match=reason) as info:
        plan_trajectory(names, times, positions, interface=CABLES, start=START, **extra)
    assert info.value.code == code


def test_a_robot_motor_in_another_mode_is_no_joint_of_a_trajectory():
    motors = Interface("rest_length", ("a", "b"), (True, True), ((0.45, 1.05), (0.0, 2000.0)), (6, 7),
                       ("rest_length", "tension"))
    assert plan_trajectory(["a"], [1.0], [[0.8]], interface=motors, start=(0.9, 100.0)).command(1.0, (0.9, 100.0)) \
        == [0.8, 100.0]
    with pytest.raises(TrajectoryError, match="joint b's motor takes a tension, not a rest length") as info:
        plan_trajectory(["b"], [1.0], [[150.0]], interface=motors, start=(0.9, 100.0))
    assert info.value.code == INVALID_JOINTS


def test_the_goal_monitor_checks_the_path_then_the_goal_within_its_time():
    tr = plan_trajectory(["a", "b"], [1.0], [[0.8, 0.8]], interface=CABLES, start=START)
    tol = Tolerances((0.01, math.inf), (math.inf, math.inf), (0.001, 0.001), (math.inf, math.inf), 0.5)
    m = GoalMonitor(tr, tol)
    d = tr.sample(0.5).positions
    assert m.check(0.5, d + [0.009, 0.5]) is None                        # b has no path tolerance
    out = m.check(0.5, d + [0.02, 0.0])                                  # a is 2 cm beyond the desired
    # the error is desired - actual, the sign of FollowJointTrajectory's feedback ``error``
    assert out.code == PATH_TOLERANCE_VIOLATED and "a: position error -0.02 m (tolerance 0.01 m)" in out.message
    assert m.check(1.2, [0.8005, 0.81]) is None                           # b not there yet, 0.2 s after the end
    out = m.check(1.6, [0.8005, 0.81])
    assert out.code == GOAL_TOLERANCE_VIOLATED and "b: position error -0.01 m" in out.message
    assert m.check(1.3, [0.8005, 0.7995]).code == SUCCESSFUL
    assert m.check(1.3, [0.8005, 0.7995], [0.0, 0.0]).succeeded


def test_a_last_velocity_below_float_epsilon_is_at_rest():
    """joint_trajectory_controller compares the last point's velocities with float epsilon."""
    tr = plan_trajectory(["a"], [1.0], [[0.5]], [[1e-8]], interface=CABLES, start=START)
    assert tr.sample(2.0).positions[0] == 0.5


def test_without_a_goal_time_the_goal_waits_for_its_tolerance():
    """A goal time of inf (control_msgs' -1, or a default of 0: joint_trajectory_controller
    "will wait a potentially infinite amount of time") never fails the goal tolerance."""
    tr = plan_trajectory(["a"], [1.0], [[0.8]], interface=CABLES, start=START)
    m = GoalMonitor(tr, Tolerances((math.inf,), (math.inf,), (0.001,), (math.inf,), tolerance(-1.0, 0.5)))
    assert m.check(1e6, [0.9]) is None
    assert m.check(1e6 + 1.0, [0.8]).succeeded


@given(st.floats(allow_nan=False, allow_infinity=False), st.floats(1e-12, 1e3))
def test_any_finite_tolerance_value_reads_as_control_msgs_says(value, default):
    """JointTolerance.msg: 0 "unspecified", the default; -1 "erased" (here any value < 0), not
    checked; above 0 the bound itself."""
    bound = tolerance(value, default)
    assert bound == (default if value == 0.0 else value if value > 0.0 else math.inf)


@given(st.floats(-10.0, 10.0))
def test_a_trajectory_is_refused_exactly_when_its_last_velocity_exceeds_float_epsilon(v):
    args = (["a"], [1.0, 2.0], [[0.5], [0.6]], [[0.0], [v]])
    if abs(v) > float(np.finfo(np.float32).eps):         # 2^-23, compared in float64
        with pytest.raises(TrajectoryError, match="must end at rest") as info:
            plan_trajectory(*args, interface=CABLES, start=START)
        assert info.value.code == INVALID_GOAL
    else:
        assert plan_trajectory(*args, interface=CABLES, start=START).sample(3.0).velocities[0] == 0.0


def test_tolerance_values_follow_joint_tolerance_conventions():
    assert tolerance(0.0, 0.01) == 0.01 and tolerance(0.2, 0.01) == 0.2 and tolerance(-1.0, 0.01) == math.inf
    assert tolerance(0.0, math.inf) == math.inf                # a default of "none": not checked
    with pytest.raises(TrajectoryError):
        tolerance(math.nan, 0.01)
