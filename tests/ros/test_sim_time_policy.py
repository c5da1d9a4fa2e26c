"""The simulator node's time policy without a node or DDS, on an injected wall clock: the
free-running tick schedule, the lockstep pacer, the command hold and its timeout, the
decimation of slower topics; and the check of cable commands against a model's Interface."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.sim.model import Interface

pytestmark = pytest.mark.ros


# -- the free-running tick schedule ---------------------------------------------------------------
def test_each_tick_makes_the_steps_due_at_the_real_time_factor():
    from tensegrity_ros.nodes.sim.schedule import TickSchedule

    # 100 Hz ticks, 1 ms steps, twice real time: 20 steps per tick
    s = TickSchedule(100.0, 2.0, 1_000_000)
    k, now = 0, 0.0
    for _ in range(5):
        target = s.steps_due(k)
        assert target - k == 20
        k = target
        assert s.wait(now) == pytest.approx(0.01)
        now += 0.01
    # a tick period of 10 ms with 3 ms steps at real time: 3, 3, 4, 3, 3, 4, ... (whole steps due)
    s = TickSchedule(100.0, 1.0, 3_000_000)
    k, made = 0, []
    for _ in range(9):
        target = s.steps_due(k)
        made.append(target - k)
        k = target
    assert made == [3, 3, 4, 3, 3, 4, 3, 3, 4] and k * 3_000_000 == 90_000_000


def test_a_late_tick_resynchronises_instead_of_bursting_and_a_restart_counts_afresh():
    from tensegrity_ros.nodes.sim.schedule import MAX_LAG, TickSchedule

    s = TickSchedule(100.0, 1.0, 10_000_000)
    assert s.steps_due(0) == 1
    assert s.wait(0.0) == pytest.approx(0.01)
    # the machine stalled for 2 s: the next wait is not negative, the schedule starts again
    assert s.wait(2.0) == 0.0
    assert s.steps_due(1) == 2                        # one step's worth, not the 200 "missed"
    # a tick whose due steps would be more than MAX_LAG of simulated time slips instead
    s = TickSchedule(1.0, 1.0, 1_000_000)             # 1 Hz ticks of 1 ms steps: 1000 steps a tick
    assert 1000 * 1_000_000 > MAX_LAG * 1e9
    assert s.steps_due(0) == 1
    s.restart()
    # as fast as possible: a publish period of simulated time per tick, at least one step
    assert TickSchedule(100.0, 0.0, 10_000_000).steps_due(7) == 8
    assert TickSchedule(100.0, 0.0, 1_000_000).steps_due(7) == 17
    assert TickSchedule(100.0, 0.0, 3_000_000).steps_due(7) == 10       # 3 whole steps in 10 ms
    assert TickSchedule(1000.0, 0.0, 10_000_000).steps_due(7) == 8
    assert TickSchedule(100.0, 0.0, 10_000_000).wait(5.0) == 0.0


@given(st.floats(10.0, 1000.0), st.sampled_from([0.25, 1.0, 3.0]), st.integers(100_000, 50_000_000),
       st.lists(st.floats(0.0, 0.5), min_size=1, max_size=60))
def test_the_clock_never_runs_ahead_of_the_wall_and_a_tick_never_bursts(rate, rtf, step_ns, work):
    """Ticks whose work takes any time: simulated time stays within the wall time since the
    start (times the factor) plus one step, and no tick makes more than MAX_LAG's worth."""
    from tensegrity_ros.nodes.sim.schedule import MAX_LAG, TickSchedule

    s = TickSchedule(rate, rtf, step_ns)
    k, now = 0, 0.0
    for w in work:
        target = s.steps_due(k)
        assert target >= k
        assert (target - k) * step_ns <= max(MAX_LAG * rtf * 1e9, step_ns)
        k = target
        now += w                                       # the tick's work
        delay = s.wait(now)
        assert delay >= 0
        now += delay
        assert k * step_ns <= (now * rtf + 1.0 / rate * rtf) * 1e9 + step_ns


# -- the lockstep pacer ----------------------------------------------------------------------------
def test_paced_states_are_due_on_the_schedule_never_earlier_and_a_late_controller_moves_the_anchor():
    from tensegrity_ros.nodes.sim.pacer import LockstepPacer

    p = LockstepPacer(2.0, 0.01)                       # twice real time: 5 ms per 10 ms step
    assert p.due(100.0, 1) == pytest.approx(100.005)   # anchored at the first state: (100.0, step 0)
    assert p.due(100.001, 2) == pytest.approx(100.010)
    assert p.due(100.020, 3) is None                   # already due
    assert p.due(101.0, 4) is None                     # 1 s behind (> MAX_LAG): the anchor moves to now
    assert p.due(101.0, 5) == pytest.approx(101.005)
    p.restart()
    assert p.due(200.0, 9) == pytest.approx(200.005)
    assert LockstepPacer(0.0, 0.01).due(0.0, 1) is None and not LockstepPacer(0.0, 0.01).paced


# -- the command hold -------------------------------------------------------------------------------
def test_forces_drop_to_the_safe_value_after_the_timeout_of_play_and_come_back_with_a_command():
    from tensegrity_ros.nodes.sim.hold import CommandHold

    h = CommandHold([-0.35, 0.35], 0.5, [0.0, 0.0])
    assert h.effective(1000.0) == ([-0.35, 0.35], False)      # no command yet: nothing times out
    assert h.set([1.0, 2.0], 0.0) is False
    assert h.effective(0.4) == ([1.0, 2.0], False)
    assert h.effective(0.6) == ([0.0, 0.0], True)             # timed out just now: say so once
    assert h.effective(0.7) == ([0.0, 0.0], False)
    assert h.set([1.5, 2.0], 0.8) is True                     # commands resumed
    assert h.effective(0.9) == ([1.5, 2.0], False)
    assert h.fallback() == [0.0, 0.0]
    h.reset([-0.35, 0.35])
    assert h.effective(100.0) == ([-0.35, 0.35], False)


def test_a_pause_stops_the_commands_clock():
    """`sim pause`, a while, `sim play` (issue 33): no timeout on resuming, and none while
    stepping during the pause; the timeout still comes after 0.5 s more of play."""
    from tensegrity_ros.nodes.sim.hold import CommandHold

    h = CommandHold([0.0, 0.0], 0.5, [0.0, 0.0])
    h.set([1.0, 1.0], 10.0)
    h.pause(10.3)
    assert h.effective(50.0) == ([1.0, 1.0], False)           # stepping while paused
    h.resume(100.0)
    assert h.effective(100.1) == ([1.0, 1.0], False)          # 0.4 s of play since the command
    assert h.effective(100.25) == ([0.0, 0.0], True)          # 0.55 s of play
    # a command while paused is fresh when play resumes; no command before the pause: none
    h.pause(101.0)
    h.set([2.0, 2.0], 150.0)
    h.resume(200.0)
    assert h.effective(200.4) == ([2.0, 2.0], False)
    fresh = CommandHold([0.0], 0.5, [0.0])
    fresh.pause(0.0)
    fresh.set([3.0], 5.0)
    fresh.resume(60.0)
    assert fresh.effective(60.1) == ([3.0], False)


def test_rest_lengths_are_held_and_never_time_out():
    from tensegrity_ros.nodes.sim.hold import CommandHold

    h = CommandHold([0.9, 0.9], 0.5, None)
    h.set([0.8, 0.9], 0.0)
    assert h.effective(1e6) == ([0.8, 0.9], False) and h.fallback() == [0.8, 0.9]


# -- decimation ---------------------------------------------------------------------------------------
def test_slower_topics_go_out_with_every_nth_publication_from_the_first():
    from tensegrity_ros.nodes.sim.decimation import Decimation

    d = Decimation(100.0, {"state": 25.0, "markers": 30.0, "off": 0.0, "fast": 500.0})
    due = [d.next() for _ in range(13)]
    assert [i for i, s in enumerate(due) if "state" in s] == [0, 4, 8, 12]
    assert [i for i, s in enumerate(due) if "markers" in s] == [0, 3, 6, 9, 12]
    assert all("fast" in s for s in due) and not any("off" in s for s in due)


def test_a_rate_above_publish_rate_is_named_in_one_warning_line():
    from tensegrity_ros.nodes.sim.decimation import cap_warnings

    lines = cap_warnings(100.0, {"state_rate": 100.0, "marker_rate": 0.0, "imu_rate": 500.0})
    assert lines == ["parameter imu_rate = 500 Hz is above publish_rate = 100 Hz: its topics go out with every "
                     "publication, at 100 Hz"]


# -- cable commands ---------------------------------------------------------------------------------
TABLE = Interface("rest_length", ("long1", "long2", "long3"), (True, True, False),
                  ((0.0, math.inf), (0.0, math.inf), (0.0, math.inf)), (0, 1, 2))


@pytest.mark.parametrize("names, values, extra, reason", [
    (["long9"], [0.8], {}, "unknown cable name 'long9' (actuated cables: long1, long2, long3)"),
    (["long1"], [math.inf], {}, "rest length of long1 is not finite"),
    (["long1"], [0.0], {}, "rest length of long1 = 0 m is outside its range (0, inf) m"),
    (["long3"], [0.8], {}, "cable long3 follows the scene's law: it takes no commands"),
    (["long1", "long2"], [0.8], {}, "2 names but 1 rest lengths"),
    ([], [0.8], {}, "unnamed command must give 3 rest lengths (long1, long2, long3), got 1"),
    (["long2", "long2"], [0.8, 0.7], {}, "cable long2 named twice"),
    (["long1"], [0.8], {"tensions": [10.0]}, "tension commands are not taken"),
    (["long1"], [0.8], {"reel_speeds": [0.1]}, "reel_speed commands are not taken"),
])
def test_bad_cable_commands_say_why(names, values, extra, reason):
    from tensegrity_ros.nodes.actuator_commands import CommandError
    from tensegrity_ros.nodes.sim.cable_commands import parse_cable_command

    with pytest.raises(CommandError, match=reason.replace("(", r"\(").replace(")", r"\)")):
        parse_cable_command(names, values, extra.get("reel_speeds", []), extra.get("tensions", []), TABLE)


def test_a_cable_command_sets_the_cables_it_names():
    from tensegrity_ros.nodes.actuator_commands import CommandError
    from tensegrity_ros.nodes.sim.cable_commands import parse_cable_command

    update = parse_cable_command(["long2", "long1"], [0.7, 0.8], [], [], TABLE)
    assert update.apply([0.9, 0.9, 0.9]) == [0.8, 0.7, 0.9]
    limited = Interface("rest_length", ("a",), (True,), ((0.5, 1.2),), (0,))
    with pytest.raises(CommandError, match=r"rest length of a = 1.3 m is outside its range \(0.5, 1.2\) m"):
        parse_cable_command(["a"], [1.3], [], [], limited)
    forces = Interface("force", ("f1", "f2"), (True, True), ((-math.inf, math.inf),) * 2, (0, 1))
    with pytest.raises(CommandError, match="send tensegrity_msgs/ActuatorForces on actuator_forces"):
        parse_cable_command(["f1"], [0.8], [], [], forces)
    none = Interface("rest_length", (), (), (), ())
    with pytest.raises(CommandError, match="no actuated cables"):
        parse_cable_command(["a"], [0.8], [], [], none)
    assert parse_cable_command([], [], [], [], none).apply([]) == []                # empty: no change
    assert parse_cable_command([], [], [], [], TABLE).apply([0.9, 0.8, 0.7]) == [0.9, 0.8, 0.7]


MOTORS = Interface("rest_length", ("a", "b", "c"), (True, True, True),
                   ((0.45, 1.05), (0.0, 2000.0), (-0.5, 0.5)), (6, 7, 8), ("rest_length", "tension", "reel_speed"))


def test_a_robot_cable_takes_its_motors_mode_from_its_own_field():
    from tensegrity_ros.nodes.sim.cable_commands import parse_cable_command

    nan = math.nan
    assert parse_cable_command(["b"], [], [], [150.0], MOTORS).apply([0.9, 100.0, 0.0]) == [0.9, 150.0, 0.0]
    assert parse_cable_command(["c", "a"], [nan, 0.8], [-0.1, nan], [], MOTORS).apply([0.9, 100.0, 0.0]) == \
        [0.8, 100.0, -0.1]
    assert parse_cable_command([], [0.7, nan, nan], [nan, nan, 0.2], [nan, 10.0, nan], MOTORS).apply(
        [0.9, 100.0, 0.0]) == [0.7, 10.0, 0.2]


@pytest.mark.parametrize("names, rest, reel, tension, reason", [
    (["b"], [0.8], [], [], "no named cable's motor takes rest lengths (leave rest_length empty)"),
    (["b"], [], [], [], "1 names but 0 tensions"),
    (["b"], [], [], [2500.0], "tension of b = 2500 N is outside its range (0, 2000) N"),
    (["c"], [], [0.6], [], "reel speed of c = 0.6 m/s is outside its range (-0.5, 0.5) m/s"),
    (["a", "b"], [0.8, 0.8], [], [1.0, 1.0], "cable a's motor takes a rest length [m] (rest_length): its tension "
                                             "must be NaN (not set)"),
    (["b"], [], [], [math.nan], "tension of b is not finite"),
])
def test_bad_motor_mode_commands_say_why(names, rest, reel, tension, reason):
    from tensegrity_ros.nodes.actuator_commands import CommandError
    from tensegrity_ros.nodes.sim.cable_commands import parse_cable_command

    with pytest.raises(CommandError, match=re.escape(reason)):
        parse_cable_command(names, rest, reel, tension, MOTORS)


def test_a_real_tension_motors_range_reads_from_0_in_the_message():
    """The compiled robot states its motors' closed ranges one float further out; at 0 that
    float is subnormal and read "(-4.94066e-324, 2000) N" in the refusal."""
    from tensegrity_core.sim import Simulator
    from tensegrity_ros.nodes.actuator_commands import CommandError
    from tensegrity_ros.nodes.sim.cable_commands import parse_cable_command

    scene = {"name": "six_bar_modes", "model": {"kind": "robot", "robot": "six_bar"}, "initial": {"drawn": True},
             "duration": 1.0, "effects": ["inertia", "cables", {"motors": {"modes": {"c0_4": "tension"}}}, "gravity"]}
    interface = Simulator(scene).interface
    with pytest.raises(CommandError, match=re.escape("tension of c0_4 = -5 N is outside its range (0, 2000) N")):
        parse_cable_command(["c0_4"], [], [], [-5.0], interface)


#: 24 motor cables as the 6-bar's: rest lengths in (0.45, 1.05) m, two of them following a law.
MOTORS_24 = Interface("rest_length", tuple(f"m{i}" for i in range(24)), tuple(i not in (5, 17) for i in range(24)),
                      ((0.45, 1.05),) * 24, tuple(range(6, 30)))


@given(st.lists(st.sampled_from([0.75, 0.45, 1.05, 0.2, 1.5, math.nan, math.inf, -math.inf, 0.4500001]),
                min_size=24, max_size=24),
       st.one_of(st.none(), st.permutations(range(24)).map(lambda p: p[:7])))
def test_a_cable_command_is_taken_exactly_when_each_value_is_inside_its_commanded_cables_range(values, subset):
    """Accepted iff every named cable takes commands and its rest length is finite and inside
    its open range (all 24 in input order, or 7 named in any order); then it sets exactly those."""
    from tensegrity_ros.nodes.actuator_commands import CommandError
    from tensegrity_ros.nodes.sim.cable_commands import parse_cable_command

    indices = list(range(24)) if subset is None else list(subset)
    names = [MOTORS_24.inputs[i] for i in indices]
    given_values = [values[i] for i in indices]
    valid = all(MOTORS_24.commanded[i] and 0.45 < v < 1.05 for i, v in zip(indices, given_values))
    try:
        update = parse_cable_command(names, given_values, [], [], MOTORS_24)
    except CommandError:
        assert not valid
        return
    assert valid
    expected = [0.0] * 24
    for i, v in zip(indices, given_values):
        expected[i] = v
    assert update.apply([0.0] * 24) == expected
