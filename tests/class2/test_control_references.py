"""References of the tracking law: end-effector moves and actuator trajectories.

Oracles: the model's own acceleration along the reference against the reference's
derivatives by finite differences (dynamic consistency); the IK core's solutions at rest;
forward kinematics; the interpolation rules of control_msgs' JointTrajectory (linear
between positions, Hermite with velocities) written out by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensegrity_core.class2 import (
    PAPER_PARAMS,
    acceleration,
    damping_matrix,
    forward_kinematics,
    mass_matrix,
    nearest_solution,
    potential_gradient,
)
from tensegrity_core.class2.control import (
    INVALID_GOAL,
    INVALID_JOINTS,
    OUTSIDE_WORKSPACE,
    PEAK_SPEED_FACTOR,
    SINGULAR_PATH,
    CirclePath,
    LinePath,
    PlanningError,
    holding_forces,
    plan_move,
    rest_state,
    smooth_step,
)
from tensegrity_core.class2.control.planner import plan_path
from tensegrity_core.class2.control.trajectory import actuator_reference

P = PAPER_PARAMS
REST = rest_state(0.7, 0.7, P)
D0 = forward_kinematics(0.7, 0.7, P)


def _derivative(values, t):
    return np.gradient(values, t, axis=0, edge_order=2)


def test_smooth_step_is_rest_to_rest_and_its_derivatives_are_consistent():
    u = np.linspace(0, 1, 20001)
    s, sd, sdd = smooth_step(u)
    assert s[0] == 0 and s[-1] == 1 and sd[0] == sd[-1] == 0 and sdd[0] == sdd[-1] == 0
    assert np.allclose(_derivative(s, u), sd, atol=1e-6) and np.allclose(_derivative(sd, u), sdd, atol=1e-5)
    assert math.isclose(sd.max(), PEAK_SPEED_FACTOR, rel_tol=1e-9)


@pytest.mark.parametrize("path", [
    LinePath((D0.x, D0.y), (D0.x + 0.08, D0.y + 0.06), 2.0),
    CirclePath((D0.x, D0.y), 0.05, 4.0, phase=math.pi / 2, ramp=1.5),
])
def test_path_derivatives_match_finite_differences(path):
    t = np.linspace(0, path.duration, 40001)
    D, Dd, Ddd = path.sample(t)
    assert np.allclose(_derivative(D, t), Dd, atol=1e-6) and np.allclose(_derivative(Dd, t), Ddd, atol=1e-5)
    assert np.allclose(path.point(path.sigma(t)), D, atol=1e-12)


def test_move_reference_is_a_trajectory_of_the_dynamics_through_the_ik_solutions():
    target = (D0.x + 0.08, D0.y + 0.06)
    ref = plan_move(REST, target, P, duration=2.0, step=0.0005)
    t, q, qd, f = ref.times, ref.q, ref.qdot, ref.force
    # D follows the straight line exactly
    path = LinePath((D0.x, D0.y), target, 2.0)
    assert np.allclose(ref.end_effector, path.sample(t)[0], atol=1e-12)
    # the unactuated row holds along the reference (the damping term to second order in c)
    qdd = _derivative(qd, t)
    row3 = (mass_matrix(q, P) @ qdd[..., None])[:, 2, 0] + (damping_matrix(q, P) @ qd[..., None])[:, 2, 0] \
        + potential_gradient(q, P)[:, 2]
    inertial = np.abs((mass_matrix(q, P) @ qdd[..., None])[:, 2, 0]).max()
    inner = slice(20, -20)        # 10 ms from the ends, where the clamped spline meets rest
    assert np.abs(row3[inner]).max() < 3e-4 * inertial     # ~c^2; one sweep leaves ~c
    # so the model's acceleration under the feedforward is the reference's own
    a = acceleration(q, qd, f[:, 0], f[:, 1], P)
    assert np.allclose(_derivative(q, t)[inner], qd[inner], atol=5e-6 * np.abs(qd).max())
    assert np.allclose(qdd[inner], a[inner], atol=1e-3 * np.abs(a).max())
    # at rest at both ends, on the IK solutions, with the holding forces
    goal = nearest_solution(*target, (0.7, 0.7), P)
    assert np.allclose(q[-1], (goal.rho1, goal.rho2, goal.beta), atol=1e-9)
    assert np.allclose(q[0], REST, atol=1e-12)
    assert np.allclose(qd[[0, -1]], 0.0, atol=1e-12)
    assert np.allclose(f[0], holding_forces(0.7, 0.7, P), atol=1e-9)
    assert np.allclose(f[-1], holding_forces(goal.rho1, goal.rho2, P), atol=1e-7)


def test_move_duration_from_a_speed_limit_keeps_the_peak_speed():
    target = (D0.x + 0.08, D0.y)
    ref = plan_move(REST, target, P, max_speed=0.05)
    assert math.isclose(ref.duration, PEAK_SPEED_FACTOR * 0.08 / 0.05, rel_tol=1e-3)
    speed = np.hypot(*_derivative(ref.end_effector, ref.times).T)
    assert speed.max() <= 0.05 * (1 + 1e-4)
    both = plan_move(REST, target, P, duration=10.0, max_speed=0.05)   # the slower one wins
    assert math.isclose(both.duration, 10.0, rel_tol=1e-3)


def test_a_speed_limit_alone_goes_slower_when_its_speed_needs_more_than_the_force_budget():
    """A speed limit is a limit: a 1 cm move at 0.05 m/s would last 630/256 * 0.01 / 0.05 =
    0.49 s and need tens of N of feedforward (the rest-to-rest acceleration grows as speed^2 /
    distance), so with only the limit the move takes the shortest duration within the 4 N
    budget instead of being refused, while the same duration given as a duration is refused."""
    target = (D0.x + 0.01, D0.y)
    at_limit = PEAK_SPEED_FACTOR * 0.01 / 0.05
    with pytest.raises(PlanningError, match="over the budget of 4 N"):
        plan_move(REST, target, P, duration=at_limit, force_budget=4.0)
    ref = plan_move(REST, target, P, max_speed=0.05, force_budget=4.0)
    assert np.max(np.abs(ref.force)) <= 4.0
    assert ref.duration > 1.5 * at_limit
    speed = np.hypot(*_derivative(ref.end_effector, ref.times).T)
    assert speed.max() < 0.05
    assert np.allclose(ref.end_effector[-1], target, atol=1e-9)
    with pytest.raises(PlanningError, match="over the budget"):      # and it is the shortest (to 5 %)
        plan_move(REST, target, P, duration=0.95 * ref.duration, force_budget=4.0)


@pytest.mark.parametrize("start, target, kw, code, words", [
    ((0.7, 0.7), (3.0, 0.5), dict(duration=2), OUTSIDE_WORKSPACE, "not reachable"),
    ((0.7, 0.7), (0.2, 0.1), dict(duration=2), OUTSIDE_WORKSPACE, "not reachable"),
    ((0.7, 0.7), (0.9, 0.9999), dict(duration=2), SINGULAR_PATH, "beta_half_pi"),
    ("D(0.5, 0.95)", (1.0, 0.2), dict(duration=2), OUTSIDE_WORKSPACE, "leaves the workspace"),
    ((0.7, 0.7), (1.2, 0.5), dict(duration=0.0), INVALID_GOAL, "duration must be > 0 s, got 0 s"),
    ((0.7, 0.7), (1.2, 0.5), dict(duration=-1.0), INVALID_GOAL, "duration must be > 0 s, got -1 s"),
    ((0.7, 0.7), (1.2, 0.5), dict(max_speed=0.0), INVALID_GOAL, "max_speed must be > 0 m/s, got 0 m/s"),
    ((0.7, 0.7), (1.2, 0.5), {}, INVALID_GOAL, "give a duration"),
    ((0.7, 0.7), (math.nan, 0.5), dict(duration=2), INVALID_GOAL, "x must be a finite number"),
    ((0.7, 0.7), (1.2, math.inf), dict(duration=2), INVALID_GOAL, "y must be a finite number"),
    ((0.7, 0.7), (1.2, 0.5), dict(duration=math.inf), INVALID_GOAL, "duration must be a finite"),
    ((0.7, 0.7), (1.3, 0.8), dict(duration=1.5, force_budget=5.0), INVALID_GOAL, "allow more time"),
    ((0.7, 0.7), (1.3, 0.8), dict(duration=0.05), OUTSIDE_WORKSPACE, "allow more time"),
])
def test_bad_moves_are_refused_with_the_reason(start, target, kw, code, words):
    if isinstance(start, str):        # start where D = (0.5, 0.95)
        c = nearest_solution(0.5, 0.95, (0.5, 0.5), P)
        q = np.array([c.rho1, c.rho2, c.beta])
    else:
        q = rest_state(*start, P)
    with pytest.raises(PlanningError, match=words) as err:
        plan_move(q, target, P, **kw)
    assert err.value.code == code


def test_a_move_refused_for_the_force_budget_says_the_duration_that_fits():
    """D by (0.6, 0.09) m in 1.5 s needs over 5 N of feedforward: the refusal names a duration
    (and the matching peak speed of D) that fits, which is accepted, while 90 % of it is not."""
    target = (1.3, 0.8)
    with pytest.raises(PlanningError, match="over the budget of 5 N: allow more time") as err:
        plan_move(REST, target, P, duration=1.5, force_budget=5.0)
    assert err.value.code == INVALID_GOAL
    words = str(err.value)
    enough = float(words.split("a duration of at least ")[1].split(" s")[0])
    speed = float(words.split("a peak speed of D of at most ")[1].split(" m/s")[0])
    # the line's rest-to-rest scaling peaks at 630/256 times the mean speed (paths.py)
    length = math.dist((D0.x, D0.y), target)
    exact = 630 / 256 * length / enough
    assert exact * (1 - 6e-3) <= speed <= exact       # rounded down to 3 digits: a limit that holds
    assert 1.5 < enough < 10.0
    plan_move(REST, target, P, duration=enough, force_budget=5.0)
    plan_move(REST, target, P, max_speed=speed, force_budget=5.0)
    with pytest.raises(PlanningError, match="over the budget"):
        plan_move(REST, target, P, duration=0.9 * enough, force_budget=5.0)


def test_a_path_near_the_lambda1_set_is_refused():
    """D low and far right: rho1 + rho2 near 2L (lambda1 -> 0)."""
    path = LinePath((D0.x, D0.y), (1.9, 0.05), 3.0)
    with pytest.raises(PlanningError, match="singular set lambda1") as err:
        plan_path(path, REST, P)
    assert err.value.code == SINGULAR_PATH


# -- actuator trajectories ------------------------------------------------------------

def _traj(names=("rho1", "rho2"), times=(1.0, 2.0), pos=((0.72, 0.68), (0.75, 0.7)), vel=None, acc=None,
          start=(0.7, 0.7), **kw):
    return actuator_reference(names, times, pos, vel, acc, start_rho=start, params=P, **kw)


def test_positions_only_interpolate_linearly_from_the_start():
    ref = _traj()
    for tau, want in ((0.0, (0.7, 0.7)), (0.5, (0.71, 0.69)), (1.0, (0.72, 0.68)), (1.5, (0.735, 0.69)),
                      (2.0, (0.75, 0.7))):
        assert np.allclose(ref.sample(tau).q[:2], want, atol=1e-12)
    assert np.allclose(ref.sample(0.5).qdot[:2], (0.02, -0.02), atol=1e-9)


def test_joint_order_follows_the_names():
    a = _traj(pos=((0.72, 0.68), (0.75, 0.7)))
    b = _traj(names=("rho2", "rho1"), pos=((0.68, 0.72), (0.7, 0.75)))
    assert np.allclose(a.q, b.q) and np.allclose(a.force, b.force)


def test_velocities_give_the_cubic_hermite_segment():
    ref = _traj(times=(1.0,), pos=((0.75, 0.65),), vel=((0.1, 0.0),), start=(0.7, 0.7))
    for tau in (0.25, 0.5, 0.8):
        h00, h10, h01, h11 = 2 * tau**3 - 3 * tau**2 + 1, tau**3 - 2 * tau**2 + tau, -2 * tau**3 + 3 * tau**2, \
            tau**3 - tau**2
        want = h00 * np.array([0.7, 0.7]) + h01 * np.array([0.75, 0.65]) + h11 * np.array([0.1, 0.0]) + 0 * h10
        assert np.allclose(ref.sample(tau).q[:2], want, atol=1e-12)


def test_accelerations_give_the_quintic_segment_through_every_derivative():
    ref = _traj(times=(2.0,), pos=((0.75, 0.65),), vel=((0.0, 0.0),), acc=((0.0, 0.0),), step=0.0005)
    t = ref.times
    # quintic rest to rest: rho(t) = a + (b - a)(10 u^3 - 15 u^4 + 6 u^5)
    u = t / 2.0
    want = 0.7 + (0.75 - 0.7) * (10 * u**3 - 15 * u**4 + 6 * u**5)
    assert np.allclose(ref.q[:, 0], want, atol=1e-12)


def test_actuator_reference_beta_stays_on_its_equilibrium_and_forces_hold_at_the_end():
    ref = _traj(vel=((0.04, -0.01), (0.0, 0.0)))
    fk = forward_kinematics(0.75, 0.7, P)
    assert math.isclose(ref.q[-1, 2], fk.beta, abs_tol=1e-12)
    assert np.allclose(ref.force[-1], holding_forces(0.75, 0.7, P), atol=1e-9)
    assert np.allclose(ref.end_effector[-1], (fk.x, fk.y), atol=1e-12)
    smooth = (np.abs(ref.times - 1.0) > 0.005) & (ref.times < 1.99)   # not at the knot (the acceleration jumps)
    assert np.allclose(_derivative(ref.q, ref.times)[smooth, 2], ref.qdot[smooth, 2], atol=1e-6)


@pytest.mark.parametrize("kw, code, words", [
    (dict(names=("rho1", "theta")), INVALID_JOINTS, "unknown joint"),
    (dict(names=("rho1", "rho1")), INVALID_JOINTS, "named twice"),
    (dict(names=("rho1",), pos=((0.7,), (0.7,))), INVALID_JOINTS, "both joints"),
    (dict(times=(1.0, 1.0)), INVALID_GOAL, "increase strictly"),
    (dict(times=(2.0, 1.0)), INVALID_GOAL, "increase strictly"),
    (dict(times=(-1.0, 1.0)), INVALID_GOAL, "negative"),
    (dict(times=(1.0, math.nan)), INVALID_GOAL, "not finite"),
    (dict(pos=((0.72, math.nan), (0.75, 0.7))), INVALID_GOAL, r"^positions\[0\]: rho2 is not finite \(nan\)$"),
    (dict(pos=((0.72, 0.68), (math.inf, 0.7))), INVALID_GOAL, r"^positions\[1\]: rho1 is not finite \(inf\)$"),
    (dict(names=("rho2", "rho1"), pos=((0.72, math.nan), (0.75, 0.7))), INVALID_GOAL,    # in the goal's order
     r"^positions\[0\]: rho1 is not finite \(nan\)$"),
    (dict(pos=((0.72, 0.68), (0.75,))), INVALID_GOAL, "1 values for the 2 joints"),
    (dict(vel=((0.0, 0.0),)), INVALID_GOAL, "give all points or none"),
    (dict(acc=((0, 0), (0, 0))), INVALID_GOAL, "accelerations need velocities"),
    (dict(pos=((0.72, 0.68), (1.2, 0.7))), OUTSIDE_WORKSPACE, "outside the mechanism's domain"),
    (dict(pos=((0.72, 0.68), (0.99, 0.7))), SINGULAR_PATH, "singular set lambda2"),
    (dict(pos=((0.72, 0.68), (0.9, 1.09))), SINGULAR_PATH, "singular set lambda1"),
    (dict(pos=((0.5, 0.5), (0.9, 0.31))), SINGULAR_PATH, "singular set beta_half_pi"),
    (dict(times=(0.01, 0.02), force_budget=5.0), INVALID_GOAL, "slow it down"),
    (dict(times=(), pos=()), INVALID_GOAL, "no points"),
])
def test_bad_trajectories_are_refused_with_the_reason(kw, code, words):
    with pytest.raises(PlanningError, match=words) as err:
        _traj(**kw)
    assert err.value.code == code
