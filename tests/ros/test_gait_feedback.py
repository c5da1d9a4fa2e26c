"""The closed-loop gait's mapping from the simulator's messages to the roll controller's inputs,
without ROS (:mod:`tensegrity_ros.apps.gait_feedback`): caps from rod poses against a direct
computation and against the core simulator's own node positions; the loop's pairing of
poses and contacts by stamp, its control instants, its answers."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tensegrity_core.robot.loading import load_robot
from tensegrity_ros.apps.gait_feedback import Answer, ClockWentBack, FeedbackLoop, RodFrames

pytestmark = pytest.mark.ros

NS = 1_000_000_000
ROBOT = load_robot("six_bar")
FRAMES = RodFrames.of(ROBOT)
CABLES = tuple(ROBOT.cables.names[j] for j in ROBOT.cables.actuated)

unit = st.floats(-1.0, 1.0, allow_nan=False)
quaternion = st.tuples(unit, unit, unit, unit).filter(lambda q: np.linalg.norm(q) > 0.1)
centre = st.tuples(*[st.floats(-5.0, 5.0, allow_nan=False)] * 3)


@given(st.lists(st.tuples(quaternion, centre), min_size=6, max_size=6), st.permutations(range(6)))
def test_caps_are_the_centre_plus_minus_half_the_rod_along_its_axis(poses, order):
    """Each cap = centre +- (L/2) * (the drawn axis a -> b rotated), whatever order the bodies come in."""
    names = [ROBOT.rods.names[i] for i in order] + ["not_a_rod"]
    positions = [poses[i][1] for i in order] + [(9.0, 9.0, 9.0)]
    quats = [poses[i][0] for i in order] + [(0.0, 0.0, 0.0, 1.0)]
    nodes = FRAMES.nodes(names, positions, quats)
    for r, (a, b) in enumerate(ROBOT.rods.ends):
        drawn = ROBOT.nodes[b] - ROBOT.nodes[a]
        half = 0.5 * np.linalg.norm(drawn)
        axis = Rotation.from_quat(poses[r][0]).as_matrix() @ (drawn / np.linalg.norm(drawn))
        c = np.asarray(poses[r][1])
        np.testing.assert_allclose(nodes[a], c - half * axis, rtol=0, atol=1e-12)
        np.testing.assert_allclose(nodes[b], c + half * axis, rtol=0, atol=1e-12)


def test_nodes_of_no_listed_rod_are_nan():
    nodes = FRAMES.nodes(["rod2"], [(0.0, 0.0, 1.0)], [(0.0, 0.0, 0.0, 1.0)])
    on = set(ROBOT.rods.ends[2].tolist())
    assert all(np.isnan(nodes[i]).all() != (i in on) for i in range(len(ROBOT.node_names)))


def test_caps_from_the_simulators_poses_are_its_nodes():
    """The frames' convention is the simulator's: the 6-bar tipped over by its rolling gait
    (rods turned by tens of degrees), its body poses mapped back give its own nodes."""
    from tensegrity_core.sim import compile_scene, load_scene

    scene = load_scene("six_bar_roll").with_duration(2.5)
    model = compile_scene(scene)
    state = model.initial_state(t_end=2.5)
    model.advance(state, 2.5)
    seen = model.observe_now(state)
    turned = Rotation.from_quat(seen["body_orientations"]).magnitude()
    assert turned.max() > 0.3                              # rad: a real test of the rotation
    nodes = FRAMES.nodes(list(ROBOT.rods.names), seen["body_positions"], seen["body_orientations"])
    np.testing.assert_allclose(nodes, seen["nodes"], rtol=0, atol=1e-9)


class Probe:
    """A controller that records what it is given and answers a row per call (its count)."""

    def __init__(self, done_after: int = 10**9) -> None:
        self.calls: list[tuple[float, list[int], np.ndarray]] = []
        self.done_after = done_after

    @property
    def done(self) -> bool:
        return len(self.calls) >= self.done_after

    def update(self, t, touching, nodes):
        self.calls.append((t, sorted(int(i) for i in touching), np.array(nodes)))
        return np.full(len(CABLES), float(len(self.calls)))


def _loop(controller, rate=50.0) -> FeedbackLoop:
    return FeedbackLoop(controller, FRAMES, ROBOT.node_names, CABLES, rate=rate)


def _bodies(loop: FeedbackLoop, stamp: int) -> list[Answer]:
    return loop.on_bodies(stamp, list(ROBOT.rods.names), [(0.0, 0.0, 0.5)] * 6, [(0.0, 0.0, 0.0, 1.0)] * 6)


@given(st.lists(st.integers(1, 60_000_000), min_size=1, max_size=60), st.integers(0, 10 * NS),
       st.sampled_from([10.0, 50.0, 100.0]))
def test_the_controller_runs_on_the_first_state_at_or_after_each_instant(gaps, t0, rate):
    """States every ``gap`` ns from ``t0``: the controller runs on a state exactly when an instant
    k / rate (k = 0, 1, ... from the first state) lies in (previous state, this state]; it sees
    the time since the first state [s]; every state is answered, stamped like it."""
    probe = Probe()
    loop = _loop(probe, rate)
    stamps = list(np.cumsum([t0, *gaps]))
    period = round(NS / rate)
    assert NS % period == 0                                 # the rates above: instants on whole ns
    expected, answers = [], []
    for i, s in enumerate(stamps):
        since = s - stamps[0]
        if i == 0 or since // period > (stamps[i - 1] - stamps[0]) // period:
            expected.append(since / NS)
        answers += loop.on_contacts(int(s), []) + _bodies(loop, int(s))
    assert [t for t, _, _ in probe.calls] == expected
    assert [a.stamp_ns for a in answers] == stamps
    assert sum(1 for a in answers if a.names) == len(expected)
    assert all(a.names == CABLES and len(a.rest_lengths) == len(CABLES) for a in answers if a.names)


def test_poses_and_contacts_pair_by_stamp_whatever_comes_first():
    probe = Probe()
    loop = _loop(probe)
    caps = [ROBOT.node_names[i] for i in (3, 0, 7)]
    assert _bodies(loop, 10) == []                          # the contacts of 10 not yet in
    assert loop.on_contacts(20, ["not_a_cap"]) == []        # nor the poses of 20
    [a] = loop.on_contacts(10, caps)
    assert a.stamp_ns == 10 and a.names == CABLES
    assert probe.calls[0][1] == [0, 3, 7]
    np.testing.assert_allclose(probe.calls[0][2], FRAMES.nodes(list(ROBOT.rods.names), [(0.0, 0.0, 0.5)] * 6,
                                                               [(0.0, 0.0, 0.0, 1.0)] * 6))
    [b] = _bodies(loop, 20)                                # unknown cap names are no caps
    assert b == Answer(20) and len(probe.calls) == 1       # 10 ns later: no control instant


def test_a_state_again_gets_the_same_answer_and_a_reset_is_refused():
    probe = Probe(done_after=2)
    loop = _loop(probe)
    first = loop.on_contacts(0, []) + _bodies(loop, 0)
    assert loop.on_contacts(0, []) + _bodies(loop, 0) == first and len(probe.calls) == 1
    loop.on_contacts(20_000_000, [])
    _bodies(loop, 20_000_000)
    assert loop.done_ns == 20_000_000 and loop.elapsed() == 0.02
    loop.on_contacts(10_000_000, [])
    with pytest.raises(ClockWentBack, match=r"clock went back from 0.020 s to 0.010 s"):
        _bodies(loop, 10_000_000)


def test_a_bad_rate_is_one_line():
    with pytest.raises(ValueError, match="control rate must be a positive number of Hz, got 0"):
        _loop(Probe(), 0.0)
