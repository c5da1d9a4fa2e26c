"""The sources without a browser: the in-process simulator's run control and inputs, a bag's
timeline against an independent reader (rosbags)."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from tensegrity_ros.view.frame import Frame
from tensegrity_ros.view.scene_source import SceneSource
from tests.bags.damaged import damaged_copy

BAGS = Path(__file__).resolve().parents[2] / "bags"


class Frames:
    """A sink that keeps the frames and lets a test wait for one."""

    def __init__(self) -> None:
        self.frames: list[Frame] = []
        self.reports: list[str] = []
        self._new = threading.Condition()

    def __call__(self, frame: Frame) -> None:
        with self._new:
            self.frames.append(frame)
            self._new.notify_all()

    def report(self, text: str) -> None:
        self.reports.append(text)

    def wait(self, condition, timeout: float = 120.0) -> Frame:
        with self._new:
            assert self._new.wait_for(lambda: any(condition(f) for f in self.frames), timeout), self.reports
            return next(f for f in self.frames if condition(f))


def test_the_scene_source_steps_plays_pauses_and_takes_its_inputs():
    source = SceneSource("class2_at_rest", step=0.01)
    assert [s.name for s in source.inputs] == ["f1", "f2"] and source.inputs[0].unit == "N"
    sink = Frames()
    source.start(sink, sink.report)
    try:
        source.drive({"f1": 2.0})
        source.step(5)                       # paused at the start: 5 steps of 10 ms
        # a tick does the steps its period allows and shows them; the rest come in the next
        # ticks (a slow first step showed t = 0.01 first): wait for all five, none beyond
        stepped = sink.wait(lambda f: f.t > 0.05 - 1e-9)
        assert stepped.t == pytest.approx(0.05, abs=1e-12) and stepped.run_state == "paused"
        assert stepped.series["f:f1"] == 2.0 and stepped.series["f:f2"] == pytest.approx(0.35, abs=0.01)
        source.play()
        playing = sink.wait(lambda f: f.run_state == "playing" and f.t >= 0.2)
        source.pause()
        paused = sink.wait(lambda f: f.run_state == "paused" and f.t >= playing.t)
        source.step(1)
        after = sink.wait(lambda f: f.t > paused.t + 1e-9 and f.run_state == "paused")
        # every state is a whole number of steps from the start
        assert round(after.t / 0.01) * 0.01 == pytest.approx(after.t, abs=1e-12)
    finally:
        source.stop()
    assert any("stepping" not in r for r in sink.reports)


def test_a_bags_timeline_holds_its_states_as_an_independent_reader_decodes_them():
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    from tensegrity_ros.view.bag_source import BagSource

    source = BagSource(BAGS / "fold")
    with AnyReader([BAGS / "fold"], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        conns = [c for c in reader.connections if c.topic == "/mechanism_state"]
        decoded = [reader.deserialize(raw, c.msgtype) for c, _t, raw in reader.messages(connections=conns)]
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in decoded]
    strings = source.topology.of_kind("string")       # the colour scale: the bag's largest string tension
    assert source.tension_scale == max(float(np.max(np.asarray(m.member_forces)[strings])) for m in decoded)
    assert source.duration == pytest.approx(max(stamps) - min(stamps), abs=1e-9)
    for k in (0, len(decoded) // 2, len(decoded) - 1):
        frame = source.frame_at(source.index_at(stamps[k] - stamps[0]))
        assert frame.t == pytest.approx(stamps[k], abs=1e-9) and frame.run_state == "recorded"
        np.testing.assert_array_equal(frame.nodes, [[p.x, p.y, p.z] for p in decoded[k].nodes])
        np.testing.assert_array_equal(frame.member_forces, decoded[k].member_forces)


def test_a_bag_without_states_to_draw_is_refused_in_one_line(tmp_path):
    """A bag of the clock only (copied from the fold bag with the suite's writer)."""
    from tensegrity_ros.bag.errors import BagError
    from tensegrity_ros.bag.reader import BagReader
    from tensegrity_ros.bag.writer import BagWriter
    from tensegrity_ros.view.bag_source import BagSource

    reader = BagReader(BAGS / "fold")
    clock = next(t for t in reader.topics() if t.name == "/clock")
    encoding, text = reader.definitions()[clock.type]
    with BagWriter(tmp_path / "clock_only") as writer:
        writer.add_topic(clock, text, encoding)
        for m in reader.messages(["/clock"]):
            writer.write(m.topic, m.data, m.log_time_ns)
    with pytest.raises(BagError, match="has no tensegrity_msgs/msg/MechanismState or tensegrity_msgs/msg/CableStates topic to draw") as err:
        BagSource(tmp_path / "clock_only")
    assert "\n" not in str(err.value)


@pytest.mark.ros
def test_a_late_answer_to_an_earlier_move_is_not_shown_over_the_latest(ros_context):
    """Move D pressed again while the first goal still runs (as after "no answer ... press Move
    D again"): the first goal's late answer, a preempted goal's failure, is not shown; the
    page's lines are the latest goal's."""
    import os
    import threading
    import time

    from rclpy.action import ActionServer
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.node import Node
    from tensegrity_msgs.action import MoveEndEffector

    from tensegrity_ros.rclpy_utils.spin_thread import SpinThread
    from tensegrity_ros.view.ros_source import RosSource

    first_running, release = threading.Event(), threading.Event()

    def execute(handle):
        goal, result = handle.request, MoveEndEffector.Result()
        if goal.x == 1.0:                                  # the first goal: ends preempted, late
            first_running.set()
            release.wait(120)
            handle.abort()
            result.error_code, result.error_string = MoveEndEffector.Result.PREEMPTED, "preempted by a newer goal"
            return result
        handle.succeed()
        result.end_effector.x, result.end_effector.y = goal.x, goal.y
        return result

    namespace = f"/view_move_late_{os.getpid()}"
    server_node = Node("slow_controller", namespace=namespace, context=ros_context)
    ActionServer(server_node, MoveEndEffector, "move_end_effector", execute, callback_group=ReentrantCallbackGroup())
    executor = MultiThreadedExecutor(context=ros_context)
    executor.add_node(server_node)
    spinning = SpinThread(executor, "slow_controller").start()
    source = RosSource(namespace)
    sink = Frames()
    source.start(sink, sink.report)
    deadline = time.monotonic() + 120.0

    def until(line: str) -> None:
        while line not in sink.reports:
            assert time.monotonic() < deadline, sink.reports
            time.sleep(0.05)

    try:
        while not source.mover.server_is_ready():
            assert time.monotonic() < deadline, "the view never saw the action server"
            time.sleep(0.05)
        source.move(1.0, 0.7, 2.0)
        assert first_running.wait(120)
        source.move(1.4, 0.7, 2.0)
        until("move: D at (1.4000, 0.7000) m, 0.00 mm from the target")
        release.set()                                       # the first goal's answer comes now...
        source.move(1.3, 0.7, 2.0)                          # ...before this one's, on the same server
        until("move: D at (1.3000, 0.7000) m, 0.00 mm from the target")
        assert not [r for r in sink.reports if r.startswith("move: failed")], sink.reports
    finally:
        release.set()
        source.stop()
        spinning.stop()
        executor.shutdown()
        server_node.destroy_node()


@pytest.mark.ros
def test_a_move_the_controller_never_answers_says_so(ros_context):
    """A move_end_effector server that never takes the goal (its node is never spun: the
    action's endpoints are on the graph, its requests never read): the page's line says no
    answer came within the view's wait, and nothing else is reported after it."""
    import os
    import time

    from rclpy.action import ActionServer
    from rclpy.node import Node
    from tensegrity_msgs.action import MoveEndEffector

    from tensegrity_ros.view.ros_source import RosSource

    namespace = f"/view_move_unanswered_{os.getpid()}"
    server_node = Node("silent_controller", namespace=namespace, context=ros_context)
    ActionServer(server_node, MoveEndEffector, "move_end_effector", lambda handle: MoveEndEffector.Result())
    source = RosSource(namespace, move_answer_s=0.5)
    sink = Frames()
    source.start(sink, sink.report)
    try:
        deadline = time.monotonic() + 120.0
        while not source.mover.server_is_ready():
            assert time.monotonic() < deadline, "the view never saw the action server"
            time.sleep(0.05)
        source.move(1.45, 0.72, 2.0)
        line = "move: no answer from the controller within 0.5 s (press Move D again)"
        while line not in sink.reports:
            assert time.monotonic() < deadline, sink.reports
            time.sleep(0.05)
        moves = [r for r in sink.reports if r.startswith("move: ")]
        assert moves == ["move: D to (1.45, 0.72) m in 2 s sent", line]
    finally:
        source.stop()
        server_node.destroy_node()


def test_a_robots_sliders_span_its_motors_ranges_in_each_motors_unit(tmp_path):
    """``tensegrity view --scene`` of the 6-bar with one motor in tension and one in
    reel-speed mode (the scene of docs/ros.md): each slider spans its motor's range from
    six_bar.yaml (rest lengths [0.45, 1.05] m, tensions [0, 2000] N, reel speeds [-0.5, 0.5]
    m/s), and the simulation steps on with every slider at either end (a command outside
    the motor's range stops it)."""
    import yaml

    from tensegrity_core.robot import examples

    motor = yaml.safe_load((Path(examples.__file__).parent / "six_bar.yaml").read_text())["cable_defaults"]["motor"]
    scene = tmp_path / "six_bar_modes.yaml"
    scene.write_text("model: {kind: robot, robot: six_bar}\ninitial: {drawn: true}\nduration: 3.0\n"
                     "effects: [inertia, cables, {motors: {modes: {c0_4: tension, c0_7: reel_speed}}}, gravity, "
                     "contact, friction, sensors]\n")
    source = SceneSource(str(scene), step=0.01)
    sliders = {s.name: s for s in source.inputs}
    assert len(sliders) == 24
    expected = {"c0_4": ("N", 0.0, motor["max_tension"]), "c0_7": ("m/s", -motor["max_speed"], motor["max_speed"]),
                "c0_8": ("m", *motor["range"])}
    for name, (unit, low, high) in expected.items():
        assert (sliders[name].unit, sliders[name].low, sliders[name].high) == (unit, low, high)
    sink = Frames()
    source.start(sink, sink.report)
    try:
        for end in ("low", "high"):
            source.drive({name: getattr(s, end) for name, s in sliders.items()})
            t = sink.frames[-1].t if sink.frames else 0.0
            source.step(2)
            sink.wait(lambda f, t=t: f.t >= t + 0.02 - 1e-9)
        assert not [r for r in sink.reports if "stopped" in r], sink.reports
    finally:
        source.stop()


@pytest.mark.ros
def test_a_suite_that_stops_is_said_so_not_left_playing(cli, ros_context):
    """A real simulator (class-2, playing) stopped with Ctrl-C while the view's ROS source
    follows it: no state comes any more, and the last frame is shown again as "no simulator"
    with a line naming its time, instead of a frozen time that still reads "playing" (~9 s,
    most of it the simulator's start)."""
    import time

    from tensegrity_ros.view.ros_source import NO_SIMULATOR, RosSource

    sim = cli("node", "sim", log_name="sim")
    source = RosSource("")
    sink = Frames()
    try:
        source.first_frame(timeout=120.0)
        source.start(sink, sink.report)
        playing = sink.wait(lambda f: f.run_state == "playing")
        assert sim.stop() == 0
        gone = sink.wait(lambda f: f.run_state == NO_SIMULATOR)
        assert gone.t >= playing.t
        line = f"the simulator has gone (/get_simulation_state left the graph): the last state shown is t = {gone.t:.3f} s"
        deadline = time.monotonic() + 10.0
        while line not in sink.reports:
            assert time.monotonic() < deadline, sink.reports
            time.sleep(0.05)
    finally:
        source.stop()


@pytest.mark.parametrize("keep", [6, 30], ids=["stamp cut", "body cut"])
def test_a_message_that_cannot_be_decoded_refuses_the_bag_in_one_line(tmp_path, keep):
    """A state cut short inside its header stamp (the stamp's own read) or after it (its
    decode): a BagError naming the bag, the topic and the message, not the CDR reader's
    traceback; the command says it in one line with exit code 1."""
    from tensegrity_ros.bag.errors import BagError
    from tensegrity_ros.view.bag_source import BagSource
    from tests.ros_support import run_cli_here

    damaged_copy(BAGS / "fold", tmp_path / "damaged", "/mechanism_state", 3, keep)
    with pytest.raises(BagError, match=f"/mechanism_state cannot be decoded \\({keep} bytes: ") as err:
        BagSource(tmp_path / "damaged")
    assert "\n" not in str(err.value) and str(tmp_path / "damaged") in str(err.value)
    res = run_cli_here("view", str(tmp_path / "damaged"), "--port", "0")
    assert res.returncode == 1 and res.stderr.splitlines() == [f"error: {err.value}"]


def test_a_damaged_state_met_while_playing_is_reported_and_the_replay_goes_on(tmp_path):
    """The 6-bar's bag with one body state cut after its stamp: it opens (a robot's states are
    decoded as they are shown), the frame of that state is refused with the reason, and the
    replay goes on to the bag's end showing the states after it."""
    from tensegrity_ros.bag.errors import BagError
    from tensegrity_ros.view.bag_source import BagSource

    damaged_copy(BAGS / "six_bar_roll", tmp_path / "damaged", "/six_bar/body_states", 40, 40)
    source = BagSource(tmp_path / "damaged", scene="six_bar_rest")
    with pytest.raises(BagError, match=r"stamped [0-9.]+ s \(41 of [0-9]+\) on /six_bar/body_states cannot be "):
        source.frame_at(40)
    after, last = source.frame_at(41).t, source.frame_at(len(source._times) - 1).t
    sink, refused = Frames(), threading.Event()

    def report(text: str) -> None:
        sink.report(text)
        if text.startswith("error: "):
            refused.set()

    source.start(sink, report)
    try:
        source.seek(source._times[40] - source.t0)     # scrubbed onto the damaged state
        assert refused.wait(120), sink.reports
        source.seek(after - source.t0)                 # the next one shows
        sink.wait(lambda f: f.t == after)
        source.set_rate(8.0)
        source.play()
        sink.wait(lambda f: f.t == last)
    finally:
        source.stop()
    errors = [r for r in sink.reports if r.startswith("error: ")]
    assert all("(41 of " in r and "/six_bar/body_states cannot be decoded (40 bytes: " in r for r in errors), errors
