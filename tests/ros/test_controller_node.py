"""The tensegrity_controller node and its two actions over real DDS (issue 15).

A real ``tensegrity node sim`` and a real ``tensegrity node controller`` in their own
namespace; the goals come from action clients in this process. The simulator runs in
lockstep at 100 Hz (the controller's design rate), paced at real time: every step waits for
the controller's command, so the closed loop is the sampled-data loop of the core whatever
the machine's load (a slow controller slows the clock, it never skips a step), while
cancels and preemptions sent on wall time land where they would on a real-time machine.
The simulator starts paused and plays once the controller holds it.

The tests that start a simulator and a controller of their own come first: the module's
pair (``suite``), started by the first test that asks for it, runs until the module ends, and
would otherwise keep stepping beside theirs. The tests on the pair that reset and stop its
simulator come last among those on the pair, the stop at the very end.
"""

from __future__ import annotations

import math
import re
import time

import pytest

from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics
from tensegrity_ros.rclpy_utils.futures import spin_until_done
from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard
from tests.ros_support import FeedbackLog, open_context, run_cli_here

pytestmark = pytest.mark.ros

D0 = forward_kinematics(0.7, 0.7, PAPER_PARAMS)
SIM_ARGS = ("-p", "publish_rate:=100.0", "-p", "lockstep:=true", "-p", "lockstep_real_time_factor:=1.0",
            "-p", "initial_state:=paused", "-p", "lockstep_timeout:=30.0")
#: The controller's watchdog in these tests: in lockstep the loop is two processes deep, and a
#: stall of either on a loaded machine must not read as a stopped simulator (the stopped-simulator
#: test kills the simulator and waits for this).
CONTROLLER_ARGS = ("-p", "state_timeout:=2.0")


class Client:
    """Action clients and a joint-state listener in this process."""

    def __init__(self, ctx, namespace: str):
        import rclpy
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import JointState
        from tensegrity_msgs.action import FollowActuatorTrajectory, MoveEndEffector
        from tensegrity_msgs.msg import ActuatorForces

        self.node = rclpy.create_node("controller_test_client", namespace=namespace, context=ctx)
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)
        # the feedback topics' readers before the probe below: matched once it is answered
        move_feedback = FeedbackLog(self.node, MoveEndEffector, "move_end_effector")
        follow_feedback = FeedbackLog(self.node, FollowActuatorTrajectory, "follow_actuator_trajectory")
        self.move = ActionClient(self.node, MoveEndEffector, "move_end_effector")
        self.follow = ActionClient(self.node, FollowActuatorTrajectory, "follow_actuator_trajectory")
        self._feedback = {self.move: move_feedback, self.follow: follow_feedback}
        self.joints: list = []
        self.commands: list = []
        self.node.create_subscription(JointState, "joint_states", self.joints.append, 10)
        self.node.create_subscription(ActuatorForces, "actuator_forces", self.commands.append, 100)
        self.Move, self.Follow = MoveEndEffector, FollowActuatorTrajectory
        for client, name in ((self.move, "move_end_effector"), (self.follow, "follow_actuator_trajectory")):
            assert wait_for_action_server(self.node, client, 60), "no action server"
            assert wait_until_server_heard(self.node, name, lambda f, t: spin_until_done(self.executor, f, t), 60)

    def spin_until(self, cond, timeout: float = 60.0) -> None:
        end = time.monotonic() + timeout
        while not cond():
            assert time.monotonic() < end, "condition not met in time"
            self.executor.spin_once(timeout_sec=0.02)

    def send(self, client, goal):
        """Send ``goal``; returns (goal handle, its feedback as it comes: a
        :class:`tests.ros_support.GoalFeedback`)."""
        sent = client.send_goal_async(goal)
        self.spin_until(sent.done, 30)
        handle = sent.result()
        assert handle.accepted
        return handle, self._feedback[client].view(handle)

    def result(self, handle, timeout: float = 60.0):
        fut = handle.get_result_async()
        self.spin_until(fut.done, timeout)
        return fut.result().status, fut.result().result

    def run(self, client, goal, timeout: float = 60.0):
        handle, feedback = self.send(client, goal)
        status, result = self.result(handle, timeout)
        return status, result, feedback

    def wait_sim(self, seconds: float) -> None:
        """Spin until the joint states' (simulated) time has advanced by ``seconds``."""
        self.joints.clear()
        self.spin_until(lambda: self.joints)
        t0 = _stamp(self.joints[-1])
        self.spin_until(lambda: _stamp(self.joints[-1]) >= t0 + seconds)

    def end_effector(self):
        self.joints.clear()
        self.spin_until(lambda: self.joints)
        js = self.joints[-1]
        r1, b = js.position[0], js.position[2]
        return r1 + math.cos(b), math.sin(b), js


def _stamp(js) -> float:
    return js.header.stamp.sec + 1e-9 * js.header.stamp.nanosec


def _start(cli, namespace: str, *controller_args: str, scene: str | None = None, play: bool = True):
    """The simulator (paused) and the controller; once the controller holds the mechanism the
    simulator plays (``play``)."""
    scene_args = ("-p", f"scene:={scene}") if scene else ()
    sim = cli("node", "sim", "--ros-args", "-r", f"__ns:={namespace}", *SIM_ARGS, *scene_args, log_name="sim")
    ctl = cli("node", "controller", "--ros-args", "-r", f"__ns:={namespace}", *scene_args, *CONTROLLER_ARGS,
              *controller_args, log_name="controller")
    sim.wait_for("publishing at")
    ctl.wait_for("holding rho")
    if play:
        _sim_control(namespace, "play")
    return sim, ctl


def _sim_control(namespace: str, action: str) -> None:
    # in this process (no interpreter start, ~1.5 s of CPU): the test is about the controller
    out = run_cli_here("sim", action, "--ros-args", "-r", f"__ns:={namespace}")
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    """One simulator + controller for the module's goals: (a client, the controller, the simulator)."""
    from tests.ros_support import Proc

    folder = tmp_path_factory.mktemp("controller")
    procs = []

    def cli(*args, log_name="proc"):
        procs.append(Proc(list(args), folder / f"{log_name}.log"))
        return procs[-1]

    sim, ctl = _start(cli, "/ctl")
    with open_context() as ctx:
        yield Client(ctx, "/ctl"), ctl, sim
    for p in procs:
        p.stop()


def _settling(feedback) -> bool:
    """Whether a feedback of the settling phase has come: the result may come first (another
    topic), and with it has come every feedback of the moving phase."""
    return any(f.phase == "settling" for f in feedback)


def _traj(names=("rho1", "rho2"), points=((1.0, (0.71, 0.69)), (2.0, (0.72, 0.7)))):
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    traj = JointTrajectory(joint_names=list(names))
    for t, pos in points:
        sec = math.floor(t)
        traj.points.append(JointTrajectoryPoint(positions=list(pos),
                                                time_from_start=Duration(sec=int(sec), nanosec=int((t - sec) * 1e9))))
    return traj


def test_a_simulator_driven_into_a_singular_set_aborts_the_running_goal(cli, ros_context, tmp_path):
    """A dead load of 1 N along +X on D, which the controller does not model, is more than a
    0.5 N controller can resist: D is pulled out until rho1 reaches L (lambda2 -> 0; about
    4 s in, by the core's sampled run of the same loop). The goal is sent while the
    simulator is paused and it plays once the goal has taken over, so the run is the same
    every time."""
    import yaml

    from tensegrity_core.sim.scene import scene_path

    scene = yaml.safe_load(scene_path("class2_at_rest").read_text())
    scene["name"] = "pulled_out"
    scene["effects"].append({"loads": {"D": [1.0, 0.0, 0.0]}})
    path = tmp_path / "pulled_out.yaml"
    path.write_text(yaml.safe_dump(scene))
    # the goal waits for the simulator to play (a CLI call, seconds on a loaded machine): the
    # watchdog must not count that pause as a stopped simulator
    sim, ctl = _start(cli, "/ctl_sing", "-p", "max_force:=0.5", "-p", "state_timeout:=60.0", scene=str(path),
                      play=False)
    client = Client(ros_context, "/ctl_sing")
    x0, y0, _ = client.end_effector()
    handle, feedback = client.send(client.move, client.Move.Goal(x=x0 + 0.01, y=y0, duration=20.0))
    client.spin_until(lambda: feedback)                     # the goal has taken over
    _sim_control("/ctl_sing", "play")
    status, res = client.result(handle, 120)
    assert status == 6 and res.error_code == client.Move.Result.SINGULAR_STATE, res.error_string
    # the state the controller aborted at, as its message reports it (the client's own last
    # joint state may be an older one: its subscription runs behind the controller's)
    found = re.search(r"at (\w+)/L = ([-+.\deE]+) .*rho = \(([-.\d]+), ([-.\d]+)\) m", res.error_string)
    assert found, res.error_string
    reported, value, rho1 = found[1], float(found[2]), float(found[3])
    assert reported == "lambda2" and 0.0 < value < 0.01
    # lambda2/L = sqrt(1 - (rho1/L)^2): rho1 within its printed 0.05 mm of the length it implies
    assert abs(rho1 - PAPER_PARAMS.L * math.sqrt(1.0 - value**2)) <= 6e-5
    assert ctl.popen.poll() is None


def test_a_repeated_state_gets_the_same_answer_and_does_not_advance_the_law(cli, ros_context):
    """The states come from this test, not a simulator. Two controllers see the same three
    samples (rest; 2 mm off in rho1; 4 mm off, 10 ms apart); one of them gets the second sample
    four times. Each repeat is answered with that sample's answer (same stamp, same forces), and
    the third sample's answer is the same from both: the repeats did not advance the law (its
    integral of the 2 mm error would otherwise have grown three more steps)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import ActuatorForces

    node = rclpy.create_node("repeat_test", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    answers: dict[str, list] = {"a": [], "b": []}
    pubs = {}
    for ns in answers:
        cli("node", "controller", "--ros-args", "-r", f"__ns:=/rep_{ns}", log_name=f"controller_{ns}")
        pubs[ns] = node.create_publisher(JointState, f"/rep_{ns}/joint_states", 10)
        node.create_subscription(ActuatorForces, f"/rep_{ns}/actuator_forces", answers[ns].append, 100)

    def state(t_ns: int, rho1: float) -> JointState:
        msg = JointState(name=["rho1", "rho2", "beta"], position=[rho1, 0.7, D0.beta], velocity=[0.0, 0.0, 0.0])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 10**9)
        return msg

    def answered(ns: str, msg: JointState) -> list:
        return [a for a in answers[ns] if a.header.stamp == msg.header.stamp]

    def ask(ns: str, msg: JointState) -> ActuatorForces:
        """Publish ``msg`` until one more answer stamped with its time comes (every second: the
        first copies may go out before discovery has matched the two ends)."""
        n = len(answered(ns, msg))
        end = time.monotonic() + 60.0
        while len(answered(ns, msg)) == n:
            assert time.monotonic() < end, f"controller {ns} did not answer"
            pubs[ns].publish(msg)
            again = time.monotonic() + 1.0
            while len(answered(ns, msg)) == n and time.monotonic() < again:
                executor.spin_once(timeout_sec=0.02)
        return answered(ns, msg)[-1]

    samples = [state(0, 0.7), state(10_000_000, 0.702), state(20_000_000, 0.704)]
    last = {}
    for ns in answers:
        ask(ns, samples[0])
        first = ask(ns, samples[1])
        if ns == "a":
            for _ in range(3):
                assert list(ask(ns, samples[1]).force) == list(first.force)
        last[ns] = ask(ns, samples[2])
    assert list(last["a"].force) == list(last["b"].force)
    assert list(last["a"].force) != list(answered("a", samples[0])[0].force)   # the samples moved the law


def test_the_demo_client_connects_to_a_controller_that_missed_the_first_state(cli, ros_context):
    """The demo's loop check (``ControllerClient.connect``) against the race that stopped the
    demo once under load: the simulator (paused, lockstep, no republishing) publishes its state
    at t = 0 once, before the controller can receive it. Here the controller is started only
    after that first state was seen, so it cannot have it; ``connect`` publishes it again until
    answered, and then a lockstep step runs on the controller's command (no step timed out)."""
    import threading

    import rclpy

    from tensegrity_ros.apps.demo_moves import ControllerClient
    from tensegrity_ros.apps.sim_client import SimClient

    sim = cli("node", "sim", "--ros-args", "-r", "__ns:=/conn", "-p", "lockstep:=true", "-p", "initial_state:=paused",
              "-p", "paused_publish_rate:=0.0", "-p", "lockstep_timeout:=30.0", log_name="sim")
    sim.wait_for("publishing at")
    client = SimClient(rclpy, "conn_client", context=ros_context, namespace="/conn")
    try:
        ctl = ControllerClient(client)
        client.wait_for_services()
        failure: list = []

        def connect() -> None:
            try:
                ctl.connect(timeout=90.0, ask_every=2.0)
            except Exception as err:  # noqa: BLE001 - reported by the test
                failure.append(err)

        thread = threading.Thread(target=connect)
        thread.start()
        client.wait_joint(0)                        # the first state went out: nobody answers it
        controller = cli("node", "controller", "--ros-args", "-r", "__ns:=/conn", log_name="controller")
        thread.join(120)
        assert not thread.is_alive() and not failure, failure
        assert "holding rho" in controller.stderr()
        client.step(1)
        client.wait_joint(10_000_000)
        assert "no command for step" not in sim.stderr()
    finally:
        client.close()


def test_a_manual_command_takes_over_from_the_controller_until_its_next_goal(cli, ros_context):
    """Issue 33: `up` then `send-forces` fought the controller's hold. A command on
    actuator_forces from another node takes over: the running goal ends PREEMPTED with the
    reason, the controller sends nothing more (the states then run under the sent forces),
    and its next goal makes it command again."""
    from action_msgs.msg import GoalStatus

    ns = "/manual"
    sim = cli("node", "sim", "--ros-args", "-r", f"__ns:={ns}", "-p", "command_timeout:=0.0", log_name="sim")
    ctl = cli("node", "controller", "--ros-args", "-r", f"__ns:={ns}", *CONTROLLER_ARGS, log_name="controller")
    sim.wait_for("publishing at")
    ctl.wait_for("holding rho")
    client = Client(ros_context, ns)
    x0, y0, _ = client.end_effector()
    handle, feedback = client.send(client.move, client.Move.Goal(x=x0 + 0.01, y=y0, duration=20.0))
    client.spin_until(lambda: len(feedback) > 5)
    sender = cli("send-forces", "-0.35", "0.35", "--rate", "50", "--ros-args", "-r", f"__ns:={ns}", log_name="send")
    status, result = client.result(handle)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == client.Move.Result.PREEMPTED
    assert "actuator_forces from another node took over" in result.error_string
    ctl.wait_for("another node commands actuator_forces")
    # once the sent forces act, the states run under them: the controller sends nothing more.
    # Were it still answering every state, no 40 states in a row would carry the sent forces; a
    # command it sent before it stopped may still arrive after one of the sender's (DDS keeps
    # one writer's messages in order, not two writers': a lost message comes again a heartbeat
    # later) and act until the sender's next, so the run is waited for, not the first 40 states
    def sent_in_a_row() -> int:
        run = 0
        for j in reversed(client.joints):
            if tuple(j.effort[:2]) != (-0.35, 0.35):
                break
            run += 1
        return run

    client.joints.clear()
    client.spin_until(lambda: sent_in_a_row() >= 40)
    sender.kill()                                   # (its exit code on a signal is test_shutdown's matter)
    handle, _ = client.send(client.move, client.Move.Goal(x=x0, y=y0, duration=1.0))
    ctl.wait_for("the controller commands actuator_forces again")
    handle.cancel_goal_async()
    client.node.destroy_node()



def test_move_reaches_the_target_within_its_tolerance_with_feedback(suite):
    client, _, _ = suite
    x0, y0, _ = client.end_effector()
    target = (x0 + 0.03, y0 + 0.02)
    goal = client.Move.Goal(x=target[0], y=target[1], duration=1.5)       # default tolerance 0.1 mm
    status, res, feedback = client.run(client.move, goal)
    assert res.error_code == client.Move.Result.SUCCESSFUL, res.error_string
    assert status == 4                                      # GoalStatus.STATUS_SUCCEEDED
    assert res.settled_error < 1e-4
    assert math.hypot(res.end_effector.x - target[0], res.end_effector.y - target[1]) < 1e-4
    assert 0 < res.max_force <= 5.0
    client.spin_until(lambda: _settling(feedback))          # with it every feedback before (one writer)
    phases = [f.phase for f in feedback]
    assert phases[0] == "moving" and phases[-1] == "settling"
    times = [f.time_from_start for f in feedback]
    assert times == sorted(times) and len(feedback) > 50   # ~100 per simulated second
    x, y, _ = client.end_effector()                         # and it holds there
    assert math.hypot(x - target[0], y - target[1]) < 2e-4


def test_a_move_with_neither_duration_nor_speed_takes_the_controllers_max_speed(suite):
    """0 is "not given" for both, as for goal_tolerance: with neither the controller's
    max_speed (0.05 m/s) applies: the move's rest-to-rest scaling peaks at 630/256 times the
    mean speed (paths.py), so a 3 cm move lasts 630/256 * 0.03 / 0.05 = 1.48 s."""
    client, _, _ = suite
    x0, y0, _ = client.end_effector()
    status, res, feedback = client.run(client.move, client.Move.Goal(x=x0 + 0.03, y=y0))
    assert res.error_code == client.Move.Result.SUCCESSFUL, res.error_string
    duration = 630 / 256 * 0.03 / 0.05
    client.spin_until(lambda: _settling(feedback))
    moving = [f.time_from_start for f in feedback if f.phase == "moving"]
    settling = [f.time_from_start for f in feedback if f.phase == "settling"]
    assert duration - 0.02 <= moving[-1] < duration <= settling[0] < duration + 0.02
    _, res, _ = client.run(client.move, client.Move.Goal(x=x0, y=y0, duration=2.0))   # back, for the next tests
    assert res.error_code == client.Move.Result.SUCCESSFUL, res.error_string


def test_a_short_move_without_a_duration_goes_slower_than_the_speed_limit_within_the_force_budget(suite):
    """`tensegrity move X Y` with neither duration nor speed, 1 cm away: at the controller's
    max_speed (0.05 m/s) the move would last 630/256 * 0.01 / 0.05 = 0.49 s and need tens of N
    of feedforward (acceleration ~ speed^2 / distance), over the 4 N budget (max_force 5 N x
    force_budget 0.8). A speed limit is a limit, so the move goes slower and succeeds."""
    client, _, _ = suite
    x0, y0, _ = client.end_effector()
    status, res, feedback = client.run(client.move, client.Move.Goal(x=x0 + 0.01, y=y0))
    assert res.error_code == client.Move.Result.SUCCESSFUL, res.error_string
    assert status == 4 and res.settled_error < 1e-4 and 0 < res.max_force <= 5.0
    client.spin_until(lambda: _settling(feedback))
    moving = [f.time_from_start for f in feedback if f.phase == "moving"]
    assert moving[-1] > 1.5 * 630 / 256 * 0.01 / 0.05      # stretched, not the limit's 0.49 s
    _, res, _ = client.run(client.move, client.Move.Goal(x=x0, y=y0, duration=2.0))   # back, for the next tests
    assert res.error_code == client.Move.Result.SUCCESSFUL, res.error_string


def test_follow_reaches_the_last_point_with_desired_actual_error_feedback(suite):
    client, _, _ = suite
    _, _, js = client.end_effector()
    r1, r2 = js.position[0], js.position[1]
    from builtin_interfaces.msg import Duration
    from tensegrity_msgs.msg import JointTolerance

    x0, y0, _ = client.end_effector()
    mm = [JointTolerance(name=n, position=1e-3) for n in ("rho1", "rho2")]
    goal = client.Follow.Goal(trajectory=_traj(points=((1.0, (r1 + 0.01, r2 - 0.01)), (2.0, (r1 + 0.02, r2)))),
                              goal_tolerance=mm, goal_time_tolerance=Duration(sec=8))
    status, res, feedback = client.run(client.follow, goal)
    assert res.error_code == client.Follow.Result.SUCCESSFUL, res.error_string
    assert all(abs(e) <= 1e-3 for e in res.final_error)
    fb = feedback[len(feedback) // 2]
    assert list(fb.joint_names) == ["rho1", "rho2"]
    for k in (0, 1):
        # control_msgs (joint_trajectory_controller's feedback, JointTrajectoryControllerState:
        # "essentially reference - feedback"): desired - actual
        assert fb.error.positions[k] == pytest.approx(fb.desired.positions[k] - fb.actual.positions[k], abs=1e-12)
    # back to rest where it started, for the tests after this one
    _, res, _ = client.run(client.move, client.Move.Goal(x=x0, y=y0, duration=3.0))
    assert res.error_code == client.Move.Result.SUCCESSFUL, res.error_string


@pytest.mark.parametrize("goal, code, words", [
    (dict(x=3.0, y=0.5, duration=2.0), "OUTSIDE_WORKSPACE", "not reachable"),
    (dict(x=math.nan, y=0.5, duration=2.0), "INVALID_GOAL", "x must be a finite number"),
    (dict(x=1.3, y=0.7, duration=-1.0), "INVALID_GOAL", "duration must be > 0"),
    (dict(x=1.3, y=0.7, max_speed=math.inf), "INVALID_GOAL", "max_speed must be a finite number"),
    (dict(x=0.9, y=0.9999, duration=2.0), "SINGULAR_PATH", "beta_half_pi"),
    (dict(x=0.0, y=1.0, duration=2.0), "SINGULAR_PATH", "singular set folded"),  # solve_ik names it too
    (dict(x=1.3, y=0.8, duration=1.5), "INVALID_GOAL", "allow more time: a duration of at least"),
])
def test_bad_moves_are_refused_with_the_reason_and_the_hold_continues(suite, goal, code, words):
    client, _, _ = suite
    before = client.end_effector()
    status, res, feedback = client.run(client.move, client.Move.Goal(**goal))
    assert res.error_code == getattr(client.Move.Result, code), res.error_string
    assert words in res.error_string
    assert status == 6 and not feedback                     # aborted at once
    client.commands.clear()                                 # the hold goes on: commands keep coming
    client.spin_until(lambda: len(client.commands) >= 50, 30)
    after = client.end_effector()
    assert math.hypot(after[0] - before[0], after[1] - before[1]) < 5e-4


@pytest.mark.parametrize("traj, code, words", [
    (dict(names=("rho1", "theta")), "INVALID_JOINTS", "unknown joint"),
    (dict(points=((2.0, (0.71, 0.69)), (1.0, (0.72, 0.7)))), "INVALID_GOAL", "increase strictly"),
    (dict(points=((1.0, (0.71, math.nan)),)), "INVALID_GOAL", "positions[0]: rho2 is not finite (nan)"),
    (dict(points=((1.0, (0.71, math.inf)),)), "INVALID_GOAL", "positions[0]: rho2 is not finite (inf)"),
    (dict(points=((3.0, (0.99, 0.7)),)), "INVALID_GOAL", "singular set lambda2"),
    (dict(points=((3.0, (1.2, 0.7)),)), "INVALID_GOAL", "outside the mechanism's domain"),
])
def test_bad_trajectories_are_refused_with_the_reason(suite, traj, code, words):
    client, _, _ = suite
    status, res, _ = client.run(client.follow, client.Follow.Goal(trajectory=_traj(**traj)))
    assert res.error_code == getattr(client.Follow.Result, code), res.error_string
    assert words in res.error_string and status == 6


def test_unknown_tolerance_joints_and_efforts_are_refused(suite):
    from tensegrity_msgs.msg import JointTolerance

    client, _, _ = suite
    goal = client.Follow.Goal(trajectory=_traj(), path_tolerance=[JointTolerance(name="beta", position=0.1)])
    _, res, _ = client.run(client.follow, goal)
    assert res.error_code == client.Follow.Result.INVALID_JOINTS and "beta" in res.error_string
    traj = _traj()
    traj.points[0].effort = [1.0, 1.0]
    _, res, _ = client.run(client.follow, client.Follow.Goal(trajectory=traj))
    assert res.error_code == client.Follow.Result.INVALID_GOAL and "effort" in res.error_string


def test_path_and_goal_tolerance_violations_abort_with_their_codes(suite):
    from builtin_interfaces.msg import Duration
    from tensegrity_msgs.msg import JointTolerance

    client, _, _ = suite
    _, _, js = client.end_effector()
    r1, r2 = js.position[0], js.position[1]
    moving = _traj(points=((1.0, (r1 + 0.02, r2)),))
    tight = [JointTolerance(name="rho1", position=1e-7)]
    _, res, feedback = client.run(client.follow, client.Follow.Goal(trajectory=moving, path_tolerance=tight))
    assert res.error_code == client.Follow.Result.PATH_TOLERANCE_VIOLATED, res.error_string
    assert "path tolerance" in res.error_string
    # rho1's reference rises by 0.02 m while rho1 starts from rest and trails it: the error named
    # is desired - actual > 0 (0.2 mm at the first 10 ms tick; later under load, as planning runs
    # beside the loop and the goal takes over a few ticks into it), the sign of the feedback's error
    error = float(re.search(r"rho1 position error (\S+) exceeds", res.error_string).group(1))
    assert 0.0 < error < 0.02, res.error_string
    assert all(f.error.positions[0] == f.desired.positions[0] - f.actual.positions[0] for f in feedback)
    _, _, js = client.end_effector()
    back = _traj(points=((1.0, (js.position[0] - 0.02, js.position[1])),))
    impossible = [JointTolerance(name=n, position=1e-12) for n in ("rho1", "rho2")]
    goal = client.Follow.Goal(trajectory=back, goal_tolerance=impossible,
                              goal_time_tolerance=Duration(sec=0, nanosec=200_000_000))
    _, res, _ = client.run(client.follow, goal)
    assert res.error_code == client.Follow.Result.GOAL_TOLERANCE_VIOLATED, res.error_string


def test_a_goal_time_tolerance_of_minus_one_waits_for_the_goal_tolerance(suite):
    """control_msgs' -1 ("erased"), which joint_trajectory_controller reads for the goal time
    too: no limit. A goal tolerance of 1e-12 m is never met, yet 0.5 s after the end (where a
    goal time of 0.2 s failed above) the goal runs on; a cancel ends it."""
    from builtin_interfaces.msg import Duration
    from tensegrity_msgs.msg import JointTolerance

    client, _, _ = suite
    _, _, js = client.end_effector()
    there = _traj(points=((0.5, (js.position[0] + 0.005, js.position[1])),))
    impossible = [JointTolerance(name=n, position=1e-12) for n in ("rho1", "rho2")]
    handle, feedback = client.send(client.follow, client.Follow.Goal(trajectory=there, goal_tolerance=impossible,
                                                                     goal_time_tolerance=Duration(sec=-1)))
    result = handle.get_result_async()
    client.spin_until(lambda: result.done() or any(
        fb.desired.time_from_start.sec + 1e-9 * fb.desired.time_from_start.nanosec >= 1.0 for fb in feedback))
    assert not result.done(), result.result().result.error_string
    cancel = handle.cancel_goal_async()
    client.spin_until(cancel.done)
    status, res = client.result(handle)
    assert status == 5, res.error_string                      # GoalStatus.STATUS_CANCELED
    back = _traj(points=((0.5, (js.position[0], js.position[1])),))
    _, res, _ = client.run(client.follow, client.Follow.Goal(trajectory=back, goal_time_tolerance=Duration(sec=8)))
    assert res.error_code == client.Follow.Result.SUCCESSFUL, res.error_string


def test_a_trajectory_stamped_on_the_wall_clock_is_said_in_the_log(suite):
    """A client without use_sim_time stamps its trajectory with the wall clock (1.8e9 s): as
    control_msgs' controllers, the goal waits for that simulation time, and the controller
    says so once with the likely cause instead of waiting silently; a cancel ends it."""
    import rclpy.clock

    client, ctl, _ = suite
    since = len(ctl.stderr())
    _, _, js = client.end_effector()
    traj = _traj(points=((1.0, (js.position[0], js.position[1])),))
    traj.header.stamp = rclpy.clock.Clock(clock_type=rclpy.clock.ClockType.SYSTEM_TIME).now().to_msg()
    handle, _ = client.send(client.follow, client.Follow.Goal(trajectory=traj))
    ctl.wait_for("wall-clock time (a client without use_sim_time)", since=since)
    result = handle.get_result_async()
    assert not result.done()
    cancel = handle.cancel_goal_async()
    client.spin_until(cancel.done)
    status, res = client.result(handle)
    assert status == 5 and res.error_code == client.Follow.Result.CANCELED, res.error_string


def test_a_trajectory_stamped_in_the_past_is_joined_and_one_that_ended_is_refused(suite):
    """As joint_trajectory_controller (validate_trajectory_msg refuses only a trajectory that
    has ended) and the cable controller: a trajectory whose start is past and whose end is not
    is joined where it is now (its first feedback is already 0.2 s or more into it; the joined
    hold lasts 3 s, so a controller running behind under load still has feedback to give before
    the result); one that ended before the controller's time is OLD_HEADER_TIMESTAMP."""
    from builtin_interfaces.msg import Duration, Time

    client, _, _ = suite
    client.wait_sim(0.5)                                   # a past of at least 0.5 s
    _, _, js = client.end_effector()
    here = ((0.5, (js.position[0], js.position[1])),)      # hold where it is for 0.5 s

    def since(seconds: float, hold: tuple = here) -> object:
        traj = _traj(points=hold)
        start = _stamp(js) - seconds
        traj.header.stamp = Time(sec=math.floor(start), nanosec=round((start - math.floor(start)) * 1e9) % 10**9)
        return traj

    _, res, feedback = client.run(client.follow, client.Follow.Goal(trajectory=since(0.51)))
    assert res.error_code == client.Follow.Result.OLD_HEADER_TIMESTAMP, res.error_string
    assert "ended at" in res.error_string and not feedback
    _, res, feedback = client.run(client.follow, client.Follow.Goal(trajectory=since(0.2, ((3.0, here[0][1]),)),
                                                                    goal_time_tolerance=Duration(sec=8)))
    assert res.error_code == client.Follow.Result.SUCCESSFUL, res.error_string
    taus = [f.desired.time_from_start.sec + 1e-9 * f.desired.time_from_start.nanosec for f in feedback]
    assert taus and min(taus) >= 0.2 - 1e-9, taus[:3]


def test_cancel_holds_where_the_reference_was(suite):
    client, _, _ = suite
    x0, y0, _ = client.end_effector()
    handle, feedback = client.send(client.move, client.Move.Goal(x=x0 - 0.04, y=y0, duration=8.0))
    client.spin_until(lambda: feedback and feedback[-1].time_from_start >= 2.0)    # a quarter of the time
    cancel = handle.cancel_goal_async()
    client.spin_until(cancel.done)
    status, res = client.result(handle)
    assert status == 5 and res.error_code == client.Move.Result.CANCELED   # GoalStatus.STATUS_CANCELED
    client.wait_sim(5.0)                                    # stopping from full speed takes a few seconds
    x1, y1, _ = client.end_effector()
    # The reference when the cancel landed: the goal's last feedback (every step's is kept).
    # This process reads the feedback late at load, so the cancel lands at 2 s or later in
    # simulated time, never before; wherever it lands, the mechanism stops there.
    last = feedback[-1]
    assert 2.0 <= last.time_from_start < 8.0
    # part of the way: the reference is 1.96 mm along at 2 s of 8 (the 9th-order time scaling
    # s(1/4) = 0.049 of 4 cm), short of the 4 cm target before 8 s
    assert 1e-3 < abs(last.desired.x - x0) < 0.04
    # stopped there: settled within 0.5 mm 5 s after the cancel (1e-5 to 6e-5 m measured for
    # cancels at 2 s and at full speed, 4 s)
    assert math.hypot(x1 - last.desired.x, y1 - last.desired.y) < 5e-4
    client.wait_sim(2.0)
    x2, y2, _ = client.end_effector()
    assert math.hypot(x2 - x1, y2 - y1) < 2e-4              # and holds


def test_a_new_goal_preempts_the_running_one(suite):
    client, _, _ = suite
    x0, y0, _ = client.end_effector()
    first, feedback = client.send(client.move, client.Move.Goal(x=x0 + 0.04, y=y0, duration=6.0))
    client.spin_until(lambda: feedback)                     # it runs
    status, res, _ = client.run(client.move, client.Move.Goal(x=x0, y=y0 + 0.03, duration=1.5))
    assert res.error_code == client.Move.Result.SUCCESSFUL, res.error_string
    status_first, res_first = client.result(first)
    assert status_first == 6 and res_first.error_code == client.Move.Result.PREEMPTED
    assert "preempted" in res_first.error_string


def test_a_controller_stopped_longer_than_its_state_timeout_goes_on_with_its_goal(suite):
    """A controller short of CPU, here stopped (SIGSTOP) 2.5 s, longer than its state_timeout
    (2 s), has not watched the simulator meanwhile: the lockstep simulator waited for its
    command, and its state was waiting in the controller's reader. When the controller runs
    again the goal goes on and succeeds; SIMULATOR_STOPPED would blame a simulator that
    never stopped (rclpy's executor runs a due timer, the watchdog, before a waiting
    subscription)."""
    import os
    import signal

    client, ctl, _ = suite
    x0, y0, _ = client.end_effector()
    handle, feedback = client.send(client.move, client.Move.Goal(x=x0 + 0.01, y=y0, duration=2.0))
    client.spin_until(lambda: feedback)                     # it runs
    os.killpg(ctl.popen.pid, signal.SIGSTOP)                # its session: the controller alone
    try:
        end = time.monotonic() + 2.5
        while time.monotonic() < end:                       # the client reads on meanwhile
            client.executor.spin_once(timeout_sec=0.05)
    finally:
        os.killpg(ctl.popen.pid, signal.SIGCONT)
    status, res = client.result(handle)
    assert (status, res.error_code) == (4, client.Move.Result.SUCCESSFUL), res.error_string


def test_a_reset_ends_the_running_goal_and_the_lockstep_loop_goes_on(suite):
    """ResetSimulation (clock back to 0) under a running goal: the goal ends with the reason,
    the controller holds anew where the reset put the mechanism (the scene's rest at
    rho = (0.7, 0.7) m) and answers its state, so the lockstep simulator never waits out a
    step."""
    import rclpy

    from tensegrity_ros.apps.sim_client import SimClient

    client, ctl, sim = suite
    since_sim, since_ctl = len(sim.stderr()), len(ctl.stderr())
    # the reset goes from this process (what `tensegrity sim reset` sends): a CLI process
    # started on a loaded machine took longer than the 5 s the move had left, and the move
    # then succeeded before the reset came
    sim_client = SimClient(rclpy, "reset_test", record_events=False, context=client.node.context, namespace="/ctl")
    try:
        sim_client.wait_for_services(30)
        x0, y0, _ = client.end_effector()
        # a move far longer than the reset's way here: this process reads the feedback (and
        # its 100 Hz joint states and commands) late at load, and a 6 s move once ended before
        # the reset came; an ended move would succeed, this one is cut at once
        handle, feedback = client.send(client.move, client.Move.Goal(x=x0 + 0.03, y=y0, duration=120.0))
        client.spin_until(lambda: feedback and feedback[-1].time_from_start >= 1.0)
        sim_client.reset_all()
    finally:
        sim_client.close()
    status, res = client.result(handle)
    assert status == 6 and res.error_code == client.Move.Result.SIMULATOR_STOPPED
    assert "the simulation was reset: its time went back" in res.error_string
    # states published before the reset may still be queued for this client (at load, one
    # from mid-move was read as the held state): the first after the reset is where the
    # clock goes back, and from there it runs again from 0
    def one_second_after_the_reset() -> bool:
        stamps = [_stamp(j) for j in client.joints]
        return any(b < a for a, b in zip(stamps, stamps[1:])) and stamps[-1] >= 1.0

    client.spin_until(one_second_after_the_reset)
    x, y, _ = client.end_effector()
    assert math.hypot(x - D0.x, y - D0.y) < 2e-4             # held at the initial state
    log = sim.stderr()[since_sim:]
    assert "no command for step" not in log                  # no step waited out its timeout
    # an answer in flight when the reset came is refused as stamped for another step
    assert all(float(t) > 0.5 for t in re.findall(r"command stamped (\S+) s, but", log)), log
    assert "holding anew" in ctl.stderr()[since_ctl:]


def test_a_stopped_simulator_aborts_the_running_goal(suite):
    """The last test on the module's pair: it stops the simulator."""
    client, ctl, sim = suite
    x0, y0, _ = client.end_effector()
    handle, feedback = client.send(client.move, client.Move.Goal(x=x0 + 0.03, y=y0, duration=8.0))
    client.spin_until(lambda: feedback)                     # it runs
    sim.kill()
    status, res = client.result(handle, 30)
    assert status == 6 and res.error_code == client.Move.Result.SIMULATOR_STOPPED
    assert "has not advanced" in res.error_string
    assert ctl.popen.poll() is None                          # the controller keeps running


def test_a_goal_sent_before_the_first_joint_state_waits_for_it(cli, ros_context):
    """A client may send a goal as soon as the action server is up, before the simulator's
    first joint state has reached the controller: the goal is held for it (``state_timeout``),
    not aborted with SIMULATOR_STOPPED. Here no simulator runs; the test publishes the one
    state itself after the goal was accepted, then cancels: the goal ends CANCELED (it ran)."""
    from action_msgs.msg import GoalStatus
    from sensor_msgs.msg import JointState

    fk = forward_kinematics(0.7, 0.7, PAPER_PARAMS)
    cli("node", "controller", "--ros-args", "-r", "__ns:=/early", "-p", "state_timeout:=60.0", log_name="controller")
    client = Client(ros_context, "/early")
    publisher = client.node.create_publisher(JointState, "joint_states", 10)
    handle, _ = client.send(client.move, client.Move.Goal(x=fk.x + 0.01, y=fk.y, duration=3.0))
    outcome = handle.get_result_async()
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        client.executor.spin_once(timeout_sec=0.02)
    assert not outcome.done(), outcome.result().result.error_string     # held, not refused
    steps = iter(range(10**6))

    def publish() -> None:           # the mechanism at rest, time advancing 10 ms a sample
        state = JointState(name=["rho1", "rho2", "beta"], position=[0.7, 0.7, fk.beta], velocity=[0.0, 0.0, 0.0])
        state.header.stamp.sec, ms = divmod(10 * next(steps), 1000)
        state.header.stamp.nanosec = ms * 1_000_000
        publisher.publish(state)

    client.spin_until(lambda: (publish(), client.commands)[1], 30)    # the controller holds
    cancel = handle.cancel_goal_async()
    client.spin_until(cancel.done, 30)
    client.spin_until(lambda: (publish(), outcome.done())[1], 30)     # the cancel ends on a state
    assert outcome.result().status == GoalStatus.STATUS_CANCELED, outcome.result().result.error_string
