"""Cable motors: the step response against the lag's analytic solution, the slew limit,
exactness over any split of a step, the continuous rate integrated by scipy, commands and
the payout under the tension limit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from tensegrity_core.robot import motor

taus = st.one_of(st.just(0.0), st.floats(1e-3, 5.0))
speeds = st.one_of(st.just(np.inf), st.floats(1e-3, 2.0))
rest = st.floats(0.05, 2.0)


def test_step_response_is_the_first_order_lag():
    """Without a slew limit: l0(t) = u - (u - l0(0)) exp(-t / tau), evaluated in closed form."""
    tau, u, start = 0.8, 0.3, 0.5
    for t in (0.0, 0.01, 0.5, 0.8, 2.0, 10.0):
        got = float(motor.step(start, u, tau, np.inf, t))
        assert abs(got - (u - (u - start) * np.exp(-t / tau))) <= 1e-15
    # one time constant: 63.2 % of the way
    assert abs((float(motor.step(start, u, tau, np.inf, tau)) - start) / (u - start) - (1 - np.exp(-1))) < 1e-14


def test_a_slew_limited_move_is_linear_then_exponential():
    tau, speed, start, u = 0.1, 0.05, 0.6, 0.2          # error 0.4 m, knee at speed * tau = 5 mm
    t_knee = (0.4 - speed * tau) / speed                # 7.9 s of slewing
    assert abs(float(motor.step(start, u, tau, speed, 2.0)) - (start - speed * 2.0)) < 1e-15
    knee = float(motor.step(start, u, tau, speed, t_knee))
    assert abs(knee - (u + speed * tau)) < 1e-12
    later = float(motor.step(start, u, tau, speed, t_knee + 0.3))
    assert abs(later - (u + speed * tau * np.exp(-3.0))) < 1e-12
    assert float(motor.step(start, u, 0.0, speed, 100.0)) == u      # a pure slew arrives and stays
    assert float(motor.step(start, u, 0.0, np.inf, 1e-3)) == u      # an ideal motor at once


@given(rest, rest, taus, speeds, st.floats(0.0, 3.0), st.floats(0.0, 3.0))
def test_the_step_is_exact_over_any_split(start, u, tau, speed, t1, t2):
    whole = float(motor.step(start, u, tau, speed, t1 + t2))
    split = float(motor.step(motor.step(start, u, tau, speed, t1), u, tau, speed, t2))
    assert abs(whole - split) <= 1e-12 + 1e-9 * abs(u - start)
    lo, hi = min(start, u), max(start, u)
    assert lo - 1e-15 <= whole <= hi + 1e-15                       # never overshoots


@given(rest, rest, st.floats(1e-2, 2.0), speeds)
def test_the_step_solves_the_rate_equation(start, u, tau, speed):
    sol = solve_ivp(lambda t, y: motor.rate(y, u, tau, speed), (0.0, 1.5), [start], rtol=1e-11, atol=1e-13,
                    method="DOP853")
    assert abs(sol.y[0, -1] - float(motor.step(start, u, tau, speed, 1.5))) < 1e-8


def test_commands_rest_length_and_tension_modes():
    lo, hi = 0.1, 0.6
    aims = motor.target([motor.REST_LENGTH, motor.REST_LENGTH, motor.TENSION, motor.TENSION],
                        [0.3, 0.9, 100.0, 1000.0], [0.5, 0.5, 0.5, 0.5], 1000.0, lo, hi)
    # 0.9 m is out of range; 100 N at 0.5 m needs l0 = 0.5 - 0.1; 1000 N would need 0 m < lo
    np.testing.assert_allclose(aims, [0.3, 0.6, 0.4, 0.1])
    # a tension above the motor's limit aims at the limit's rest length: 0.5 - 50/1000
    assert float(motor.target(motor.TENSION, 100.0, 0.5, 1000.0, lo, hi, t_max=50.0)) == pytest.approx(0.45)


def test_reel_speed_moves_the_rest_length_at_the_commanded_speed_within_the_slew_limit_and_range():
    lo, hi = 0.1, 0.6
    np.testing.assert_allclose(motor.reel([0.3, 0.3, 0.3, 0.598], [0.05, -0.5, 0.5, 0.05], 0.2, lo, hi, 0.1),
                               [0.305, 0.28, 0.32, 0.6])     # 5 mm, the slew limit both ways, the range's end


@given(rest, st.floats(0.0, 0.5), st.floats(10.0, 1e4), st.floats(1.0, 500.0))
def test_payout_keeps_the_tension_at_its_limit(l0, stretch, k, t_max):
    hi = l0 + 1.0
    l = l0 + stretch
    new = float(motor.payout(l0, l, k, t_max, hi))
    assert new >= l0
    assert k * (l - new) <= t_max * (1 + 1e-12) + 1e-12
    if new > l0:                                                    # paid out: exactly at the limit, less energy
        assert abs(k * (l - new) - t_max) <= 1e-9 * t_max
        assert (l - new) ** 2 <= (l - l0) ** 2
    capped = float(motor.payout(l0, l0 + 10.0, k, 1.0, l0 + 0.01))  # the spool's end: no further
    assert capped == l0 + 0.01


@given(taus, speeds, st.floats(1e-4, 1.0), st.floats(1e-6, 1e-2))
def test_settling_time_is_when_the_integrated_rate_reaches_the_tolerance(tau, speed, gap, tolerance):
    """The error of a motor from ``gap`` away, integrated by scipy from the continuous rate,
    first reaches ``tolerance`` at ``settling_time`` (an event of the integration)."""
    got = float(motor.settling_time(gap, tolerance, tau, speed))
    if gap <= tolerance:
        assert got == 0.0
        return
    if tau == 0.0 and not np.isfinite(speed):
        assert got == 0.0                                 # an ideal motor is there at once
        return
    if tau == 0.0:                                        # a pure slew: the rate jumps at the aim
        assert abs(got - (gap - tolerance) / speed) <= 1e-12 * max(got, 1.0)
        return

    def reached(_t, y):
        return y[0] - tolerance
    reached.terminal = True
    sol = solve_ivp(lambda _t, y: -np.clip(y / tau, -speed, speed), (0.0, 10 * got + 1.0), [gap],
                    events=reached, rtol=1e-11, atol=1e-14, method="DOP853")
    assert sol.t_events[0].size == 1
    assert abs(sol.t_events[0][0] - got) <= 1e-6 * got + 1e-9


def test_settling_time_of_the_three_bar_motor_is_its_lag_times_the_log_of_the_gap():
    """The 3-bar's motors (lag 1 s, no slew limit): 0.6 m to 0.1 mm takes ln(6000) s = 8.70 s."""
    assert abs(float(motor.settling_time(0.6, 1e-4, 1.0, np.inf)) - np.log(6000.0)) < 1e-12
    # the 6-bar's (lag 0.02 s, 0.5 m/s): 0.59 m of slew in 1.18 s, then 0.02 ln(100) s
    assert abs(float(motor.settling_time(0.6, 1e-4, 0.02, 0.5)) - (1.18 + 0.02 * np.log(100.0))) < 1e-12


def test_a_scenes_motors_settle_time_is_its_slowest_motors_over_its_range():
    """``joint_trajectory.motors_settle_time``: the scene's ``motors`` overrides replace the
    description's lag; a scene without ``motors`` (ideal motors) or without robot motors 0."""
    from tensegrity_core.sim import load_scene
    from tensegrity_core.sim.joint_trajectory import motors_settle_time

    three = load_scene("three_bar_drop")
    assert abs(motors_settle_time(three, ["td_0", "td_3"], 1e-4) - np.log(0.6 / 1e-4)) < 1e-9
    assert motors_settle_time(three, ["td_6"], 1e-4) == 0.0                 # a passive cable: no motor
    faster = load_scene({"model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
                         "effects": ["inertia", "cables", {"motors": {"tau": 0.1}}], "duration": 1.0})
    assert abs(motors_settle_time(faster, ["td_0"], 1e-4) - 0.1 * np.log(0.6 / 1e-4)) < 1e-9
    ideal = load_scene({"model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
                        "effects": ["inertia", "cables"], "duration": 1.0})
    assert motors_settle_time(ideal, ["td_0"], 1e-4) == 0.0
    assert motors_settle_time(load_scene("table_actuated"), ["long1"], 1e-4) == 0.0
