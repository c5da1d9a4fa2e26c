"""Play a gait on the running suite through ``control_msgs/FollowJointTrajectory`` and watch
what the robot does (``tensegrity gait``; the command's checks are in
:mod:`tensegrity_ros.cli.cmd_gait`).

While the goal runs this client collects the simulator's ``body_states`` (the robot's
centre), ``contacts`` (the caps on the floor) and ``joint_states`` (the motor cables'
tensions), each stamped with simulation time, and summarises them at the end
(:mod:`.roll_summary`).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import Any, TextIO

from tensegrity_core.errors import TensegrityError
from tensegrity_core.robot.gait import Gait
from tensegrity_ros.apps.gait_goal import TrajectoryPoints, trajectory_points
from tensegrity_ros.apps.roll_summary import REST_HOLD_S, rest_time, roll_summary

NS_PER_S = 1_000_000_000
SIM_NODE = "tensegrity_sim"


class SuiteError(TensegrityError, RuntimeError):
    """The suite cannot play the gait: one line, and the exit code (3: nothing answers)."""

    def __init__(self, message: str, code: int = 1):
        super().__init__(message)
        self.code = code


def sim_parameters(node: Any, executor: Any, names: list[str], timeout: float) -> list[Any]:
    """The running simulator's parameters ``names`` (rcl_interfaces ParameterValue each);
    SuiteError (code 3) when none answers."""
    from rcl_interfaces.srv import GetParameters
    from rclpy.parameter_client import AsyncParameterClient

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_until_answered

    client = AsyncParameterClient(node, SIM_NODE)
    where = node.get_namespace()
    # asked once the simulator has matched this client's response reader (a probe made after
    # it answered), else the answer can be lost
    if not client.wait_for_services(timeout_sec=timeout) or not wait_until_answered(
            node, GetParameters, f"{SIM_NODE}/get_parameters", lambda f, t: spin_until_done(executor, f, t), timeout):
        raise SuiteError(f"no simulator answers in namespace {where} after {timeout:g} s (is the suite up? "
                         "`tensegrity up --scene six_bar_rest`)", code=3)
    future = client.get_parameters(names)
    if not spin_until_done(executor, future, timeout):
        raise SuiteError(f"the simulator did not say its {', '.join(names)} within {timeout:g} s", code=3)
    return list(future.result().values)


def running_scene(node: Any, executor: Any, timeout: float) -> str:
    """The running simulator's ``scene`` parameter; SuiteError (code 3) when none answers."""
    return str(sim_parameters(node, executor, ["scene"], timeout)[0].string_value)


def check_scene(scene_name: str, robot_name: str, cables: Sequence[str]) -> None:
    """:class:`SuiteError` unless ``scene_name`` simulates ``robot_name`` with ``cables`` commanded."""
    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.sim import compile_scene, load_scene

    try:
        scene = load_scene(scene_name)
        model = compile_scene(scene)
    except TensegrityError as err:
        raise SuiteError(f"the running simulator's scene {scene_name!r} cannot be read here: {err}") from None
    runs = getattr(scene.model, "source", None) if scene.model.kind == "robot" else None
    if runs != robot_name:
        what = f"the robot {runs}" if runs else f"a {scene.model.kind} model, not a robot"
        raise SuiteError(f"the running suite simulates {what} (scene {scene_name!r}), not {robot_name}")
    commanded = {name for name, c in zip(model.interface.inputs, model.interface.commanded) if c}
    missing = [c for c in cables if c not in commanded]
    if missing:
        raise SuiteError(f"the running scene {scene_name!r} plays its own inputs on {', '.join(missing[:3])}"
                       f"{', ...' if len(missing) > 3 else ''}: start the suite with a scene whose motors take "
                       "commands (`tensegrity up --scene six_bar_rest`)")


def goal_of(points: TrajectoryPoints) -> Any:
    """The FollowJointTrajectory goal of ``points`` (positions only: the controller
    interpolates linearly; its default tolerances)."""
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    traj = JointTrajectory(joint_names=list(points.joint_names))
    for t, row in zip(points.times, points.positions):
        ns = round(t * NS_PER_S)
        traj.points.append(JointTrajectoryPoint(positions=list(row),
                                                time_from_start=Duration(sec=ns // NS_PER_S, nanosec=ns % NS_PER_S)))
    return FollowJointTrajectory.Goal(trajectory=traj)


class RunWatcher:
    """Subscriptions to what the robot does, every sample kept with its stamp [s]; the
    summary takes those of the goal's window (:meth:`summary_lines`)."""

    def __init__(self, node: Any, *, samples: bool = True) -> None:
        """``samples`` False: the robot's samples only from :meth:`subscribe_samples` on."""
        from tensegrity_msgs.msg import CableCommand

        self.node = node
        self.controller_answers = 0           # cable_commands seen: the controller gets the states
        self.centres: list[tuple[float, tuple[float, float, float]]] = []
        self.contacts: list[tuple[float, tuple[str, ...]]] = []
        self.cable_names: tuple[str, ...] = ()
        self.tensions: list[tuple[float, tuple[float, ...]]] = []
        self.samples: list[Any] = []
        node.create_subscription(CableCommand, "cable_commands", self._on_command, 10)
        if samples:
            self.subscribe_samples()

    def subscribe_samples(self) -> list[Any]:
        """Subscribe to the robot's samples (bodies, contacts, joint states), every one kept:
        a lockstep simulator steps as fast as its controller answers, whether this client
        keeps up or not, so samples taken long before the goal are a backlog this client
        works through one by one (at load, slower than the simulator adds to it)."""
        from rclpy.qos import HistoryPolicy, QoSProfile
        from sensor_msgs.msg import JointState
        from tensegrity_msgs.msg import CapContacts, RigidBodyStates

        from tensegrity_core.interrupts import sigint_deferred

        qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1000)   # a loaded client falls behind, loses nothing
        # never interrupted half-way (see tensegrity_core.interrupts: rclpy's create_subscription)
        with sigint_deferred(sigterm=True):
            self.samples = [self.node.create_subscription(RigidBodyStates, "body_states", self._on_bodies, qos),
                            self.node.create_subscription(CapContacts, "contacts", self._on_contacts, qos),
                            self.node.create_subscription(JointState, "joint_states", self._on_joints, qos)]
        return self.samples

    @staticmethod
    def _t(msg: Any) -> float:
        return float(msg.header.stamp.sec + msg.header.stamp.nanosec / NS_PER_S)

    def _on_command(self, msg: Any) -> None:
        self.controller_answers += 1

    def _on_bodies(self, msg: Any) -> None:
        if msg.pose:
            n = len(msg.pose)
            self.centres.append((self._t(msg), (sum(p.position.x for p in msg.pose) / n,
                                                sum(p.position.y for p in msg.pose) / n,
                                                sum(p.position.z for p in msg.pose) / n)))

    def _on_contacts(self, msg: Any) -> None:
        self.contacts.append((self._t(msg), tuple(msg.name)))

    def _on_joints(self, msg: Any) -> None:
        if not self.cable_names:
            self.cable_names = tuple(msg.name)
        if tuple(msg.name) == self.cable_names:       # effort: NaN or empty where no tension is measured
            self.tensions.append((self._t(msg), tuple(msg.effort) or (math.nan,) * len(self.cable_names)))

    def latest(self) -> float:
        """Stamp [s] of the latest joint state received (-inf: none)."""
        return self.tensions[-1][0] if self.tensions else -math.inf

    def watch_until_rest(self, executor: Any, goal_end: float, settle: float, timeout: float) -> float | None:
        """Spin until the robot is at rest after ``goal_end`` [s] (:func:`.roll_summary.rest_time`)
        and return that time [s], or None once the samples reach ``goal_end + settle`` [s] or
        none arrive for ``timeout`` s of wall time."""
        stalled, seen, looked = time.monotonic() + timeout, -math.inf, goal_end
        while time.monotonic() < stalled:
            if self.latest() > seen:             # new samples: look at the new times, back as far as the rule needs
                stalled, seen = time.monotonic() + timeout, self.latest()
                centres = [(t, c) for t, c in self.centres if t >= looked - 2 * REST_HOLD_S]
                contacts = [(t, c) for t, c in self.contacts if t >= looked - 2 * REST_HOLD_S]
                rest = rest_time([t for t, _ in centres], [c for _, c in centres],
                                 [t for t, _ in contacts], [c for _, c in contacts], looked)
                looked = max(looked, centres[-1][0]) if centres else looked
                if rest is not None and rest <= goal_end + settle:
                    return rest
                if seen >= goal_end + settle:
                    return None
            executor.spin_once(timeout_sec=0.1)
        return None

    def rest_line(self, goal_end: float, settle: float, rest: float | None, *, after: str = "the goal's end") -> str:
        """Whether and when the robot came to rest after ``goal_end`` [s] (``after`` names that moment)."""
        if rest is not None:
            return f"at rest on a face {rest - goal_end:.2f} s after {after}"
        last = [(t, c) for t, c in self.centres if t <= goal_end + settle]
        window = [(t, c) for t, c in last if t >= last[-1][0] - REST_HOLD_S] if last else []
        if len(window) < 2 or window[-1][0] <= window[0][0]:
            return f"not seen at rest within {settle:g} s after {after}"
        (t0, c0), (t1, c1) = window[0], window[-1]
        speed = math.hypot(c1[0] - c0[0], c1[1] - c0[1]) / (t1 - t0)
        return (f"still moving {settle:g} s after {after} (centre at {speed:.2f} m/s): the distance and "
                "faces above are those up to then")

    def summary_lines(self, start: float = -math.inf, end: float = math.inf,
                      hull: Sequence[Sequence[str]] | None = None) -> list[str]:
        """The summary of the samples stamped in [start, end] [s] (with ``hull``, the robot's
        hull faces as cap names: the faces touched too)."""
        def inside(samples: list[tuple[float, Any]]) -> list[tuple[float, Any]]:
            return [(t, v) for t, v in samples if start <= t <= end]

        contacts = inside(self.contacts)
        s = roll_summary([v for _, v in inside(self.centres)], [t for t, _ in contacts], [v for _, v in contacts],
                         self.cable_names, [v for _, v in inside(self.tensions)], hull=hull)
        return s.lines()


def play_gait(robot: str, gait: Gait, ros_args: list[str], *, action: str, timeout: float, settle: float,
              out: TextIO = sys.stdout) -> int:
    """Send ``gait`` as one goal to ``action`` (once :func:`check_scene` accepts the running
    simulator's scene for ``robot``), show progress on stderr, watch the robot for up to
    ``settle`` s of simulation time after the goal until it is at rest, print the result and
    the run's summary (from the goal's start to the rest, or to the end of that watch) to
    ``out``; the exit code."""
    from control_msgs.action import FollowJointTrajectory
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from tqdm import tqdm

    from tensegrity_ros.cli.ros_clients import client_node
    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard

    points = trajectory_points(gait)
    rclpy, node = client_node("tensegrity_gait", ros_args)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    client = ActionClient(node, FollowJointTrajectory, action)
    watcher = RunWatcher(node, samples=False)
    bar = None
    handle = None
    try:
        check_scene(running_scene(node, executor, timeout), robot, gait.cables)
        if not wait_for_action_server(node, client, timeout):
            raise SuiteError(f"action {node.resolve_topic_name(action)} not available after {timeout:g} s (is the "
                           "suite's cable controller up? `tensegrity up --scene six_bar_rest`)", code=3)
        wait_until_server_heard(node, action, lambda f, t: spin_until_done(executor, f, t), timeout)
        deadline = time.monotonic() + timeout
        while not watcher.controller_answers:     # it answers once active (it has the states): it takes goals
            if time.monotonic() > deadline:
                raise SuiteError(f"the cable controller answers no joint states within {timeout:g} s (is the "
                                 "simulator running? `tensegrity sim play`)", code=3)
            executor.spin_once(timeout_sec=0.1)
        # the samples from now on, matched before the goal is sent (its first samples arrive)
        samples = watcher.subscribe_samples()
        deadline = time.monotonic() + timeout
        while not all(sub.get_publisher_count() for sub in samples):
            if time.monotonic() > deadline:
                raise SuiteError(f"the simulator's body_states, contacts and joint_states not matched within "
                                 f"{timeout:g} s", code=3)
            executor.spin_once(timeout_sec=0.1)
        bar = tqdm(total=round(points.duration, 2), unit="s", file=sys.stderr, dynamic_ncols=True, mininterval=0.5,
                   desc=f"{gait.name} on {robot}", bar_format="{l_bar}{bar}| {n:.2f}/{total_fmt} s {postfix}")

        window = [math.inf, -math.inf]          # the goal's start and latest feedback [s, simulation time]

        def on_feedback(msg: Any) -> None:
            d = msg.feedback.desired.time_from_start
            stamp = RunWatcher._t(msg.feedback)
            window[0] = min(window[0], stamp - (d.sec + d.nanosec / NS_PER_S))
            window[1] = max(window[1], stamp)
            advance = round(min(d.sec + d.nanosec / NS_PER_S, points.duration), 2) - bar.n
            if advance > 0:
                bar.update(advance)           # redraws at most every mininterval

        sent = client.send_goal_async(goal_of(points), feedback_callback=on_feedback)
        if not spin_until_done(executor, sent, timeout):
            raise SuiteError(f"the cable controller did not answer the goal within {timeout:g} s", code=3)
        handle = sent.result()
        if not handle.accepted:
            raise SuiteError("the cable controller rejected the goal", code=1)
        result = handle.get_result_async()
        while not spin_until_done(executor, result, 1.0):
            pass
        handle = None
        res = result.result().result
        rest = watcher.watch_until_rest(executor, window[1], settle, timeout)
        ok = res.error_code == 0
        if ok:
            bar.n = bar.total
            bar.refresh()
        bar.close()
        codes = {v: k for k, v in vars(FollowJointTrajectory.Result).items() if k.isupper() and isinstance(v, int)}
        print(f"{'succeeded' if ok else 'failed (' + codes.get(res.error_code, str(res.error_code)) + ')'}: "
              f"{res.error_string or gait.name}", file=out)
        for line in watcher.summary_lines(window[0], window[1] + settle if rest is None else rest):
            print(f"  {line}", file=out)
        print(f"  {watcher.rest_line(window[1], settle, rest)}", file=out)
        return 0 if ok else 1
    except KeyboardInterrupt:
        if handle is not None:
            spin_until_done(executor, handle.cancel_goal_async(), 5.0)
            if bar is not None:
                bar.close()
            print("cancelled: the cables hold where they are", file=sys.stderr)
        return 130
    finally:
        if bar is not None:
            bar.close()
        executor.shutdown()
        client.destroy()
        node.destroy_node()
        rclpy.try_shutdown()
