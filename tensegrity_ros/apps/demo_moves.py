"""The demo's controller phase: end-effector moves and an actuator trajectory through the
``tensegrity_controller`` node's actions, with the simulator in lockstep.

Reproducible by construction. The simulator is paused between goals; for each goal the
client (1) waits until the controller has answered the state the simulator stands at (its
command for that step is then already with the simulator), (2) sends the goal and waits for
the feedback the controller sends when the goal takes over (from then on every step is the
goal's), (3) steps the simulator a fixed number of steps, each of which waits for the
controller's command, (4) reads the goal's result. No step depends on when a message
arrived, so two runs give the same joint states bit for bit.

Times are simulation times [s]; positions of D [m] in the mechanism's plane.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from tensegrity_core.class2 import PAPER_PARAMS, end_effector_of, forward_kinematics
from tensegrity_core.class2.names import ACTUATED_JOINTS
from tensegrity_ros.apps.sim_client import NS_PER_S, JointRecord, SimClient
from tensegrity_ros.rclpy_utils.futures import on_executor, wait_done
from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard

#: End-effector waypoints, offsets [m] from D at rho1 = rho2 = 0.7 (the scene's rest).
WAYPOINT_OFFSETS = ((0.08, 0.0), (0.08, 0.06), (-0.04, 0.06), (0.0, 0.0))
MOVE_TIME = 2.0          # s: duration of each move (MoveEndEffector.duration)
GOAL_TOLERANCE = 5e-5    # m: a move succeeds once D stays this close to its target (0.05 mm)
SETTLE_TIMEOUT = 2.0     # s after a move's end to get there (the controller's settle_timeout)
SETTLE_WINDOW = 0.2      # s D must stay within the tolerance (the controller's settle_window)
CHECK_AFTER = 2.0        # s after a move's end at which the error is measured as well
#: The actuator trajectory after the moves: (time from start [s], (rho1, rho2) [m]).
TRAJECTORY = ((2.0, (0.71, 0.69)), (4.0, (0.72, 0.70)), (6.0, (0.70, 0.70)))
TRAJECTORY_GOAL_TIME = 5.0   # s after the last point to come within the goal tolerance
TRAJECTORY_TOLERANCE = 1e-4  # m, each length at the end

#: s: the longest a wait for the controller's answer stays in a wait set at a time (Ctrl-C,
#: a Python signal handler, runs only between two waits: a wait set is not woken by it)
WAIT_SLICE = 0.1
#: ROS parameters of the demo's controller (the simulator is stepped by the demo: between
#: goals it stands paused, which the controller's watchdog must not read as a stopped one).
CONTROLLER_PARAMETERS = {"settle_timeout": SETTLE_TIMEOUT, "settle_window": SETTLE_WINDOW,
                         "state_timeout": 30.0}


@dataclass(frozen=True)
class MoveReport:
    """One move: its target [m], the action's result and what the joint states show."""

    target: tuple[float, float]
    code: int
    message: str
    settled_error: float        # m, the result's (|D - target| when it succeeded)
    settling_time: float        # s after the move's end from which D stayed within the tolerance
    max_force: float            # N, largest commanded |f| during the goal
    overshoot: float            # m, largest excursion of D past the target along the move (from
                                #    its start to CHECK_AFTER s after its end)
    error_after: float          # m, |D - target| CHECK_AFTER s after the move's end


@dataclass(frozen=True)
class TrajectoryReport:
    code: int
    message: str
    final_error: tuple[float, float]    # m, lengths at the end against the last point
    end_effector_error: float           # m
    max_path_error: float               # m, largest length error while the trajectory ran
    max_force: float                    # N


class ControllerClient:
    """Action clients of the controller, on the node of a :class:`SimClient` (whose executor
    spins them), and a listener of its commands on a node of its own that no executor spins:
    the commands are taken only where :meth:`wait_answered` needs them, on the caller's thread
    (:class:`~tensegrity_ros.rclpy_utils.inbox.Inbox`), not woken for one by one at every step
    (an executor's wake-up per message costs ~0.5 ms of CPU, :mod:`~tensegrity_ros.rclpy_utils.raw_take`).
    Its history keeps the last 1000 commands: the one waited for is always the latest, the
    answer to the state the paused simulator stands at."""

    def __init__(self, sim: SimClient) -> None:
        from rclpy.action import ActionClient
        from rclpy.node import Node
        from rclpy.qos import QoSProfile
        from tensegrity_msgs.action import FollowActuatorTrajectory, MoveEndEffector
        from tensegrity_msgs.msg import ActuatorForces

        from tensegrity_ros.rclpy_utils.inbox import Inbox

        self.sim = sim
        self.Move, self.Follow = MoveEndEffector, FollowActuatorTrajectory
        # every feedback kept while the client takes a chunk of steps (SimClient.step_received)
        feedback_qos = QoSProfile(depth=1000)
        self.move = ActionClient(sim.node, MoveEndEffector, "move_end_effector", feedback_sub_qos_profile=feedback_qos)
        self.follow = ActionClient(sim.node, FollowActuatorTrajectory, "follow_actuator_trajectory",
                                   feedback_sub_qos_profile=feedback_qos)
        self._answered: set[int] = set()
        self._commands_node = Node(f"_{sim.node.get_name()}_commands", namespace=sim.node.get_namespace(),
                                   context=sim.node.context, use_global_arguments=False,
                                   start_parameter_services=False, enable_rosout=False)
        self._commands = Inbox(self._commands_node)
        self._commands.subscribe(ActuatorForces, sim.node.resolve_topic_name("actuator_forces"), self._on_command,
                                 QoSProfile(depth=1000))

    def _on_command(self, msg: Any) -> None:
        self._answered.add(msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec)

    def wait_for_servers(self, timeout: float = 60.0) -> None:
        for client in (self.move, self.follow):
            if not wait_for_action_server(self.sim.node, client, timeout):
                raise RuntimeError(f"the controller's action {client._action_name} is not available "
                                   f"within {timeout:g} s")
            wait_until_server_heard(self.sim.node, client._action_name, wait_done, timeout)

    def connect(self, timeout: float = 60.0, ask_every: float = 2.0) -> None:
        """Return once the loop is known to be closed: the simulator reset to its state at
        t = 0 and the controller's answer to it received here. Discovery is per participant:
        that this process sees the controller's subscription says nothing of whether the
        simulator's writer has matched it, and a volatile state published before that match
        is lost (the simulator publishes it once, seen under load). So the state is published
        again (another reset: unchanged, the simulator keeps any command for it and the
        controller answers it again without advancing) every ``ask_every`` s until answered."""
        deadline = time.monotonic() + timeout
        self.sim.set_law(None)
        while True:
            self.sim.reset_all()
            try:
                self.wait_answered(0, min(ask_every, max(0.0, deadline - time.monotonic())))
                self._commands.wait(0.0)      # the answers here now are this one's, not the next wait's
                self._answered.clear()        # the next wait for t = 0 waits for the next answer
                return
            except RuntimeError:
                if time.monotonic() >= deadline:
                    raise RuntimeError(f"the controller did not answer the simulator's state within {timeout:g} s "
                                       "(is its joint_states subscription connected?)") from None

    def wait_answered(self, stamp_ns: int, timeout: float = 60.0) -> None:
        """Wait until the controller has answered the state stamped ``stamp_ns``."""
        deadline = time.monotonic() + timeout
        self._commands.wait(0.0)
        while stamp_ns not in self._answered:
            left = deadline - time.monotonic()
            if left <= 0.0:
                raise RuntimeError(f"the controller did not answer the state at t = {stamp_ns / NS_PER_S:.9f} s "
                                   f"within {timeout:g} s")
            self._commands.wait(min(left, WAIT_SLICE))

    def close(self) -> None:
        self._commands_node.destroy_node()

    def run_goal(self, action: Any, goal: Any, steps: int, from_ns: int, step_ns: int,
                 timeout: float = 120.0) -> tuple[int, Any, list[Any]]:
        """Send ``goal``, wait for its takeover feedback, step ``steps`` steps from the state
        stamped ``from_ns``, return ``(status, result, feedback list)``."""
        feedback: list[Any] = []
        started = threading.Event()

        def on_feedback(msg: Any) -> None:
            feedback.append(msg.feedback)
            started.set()

        executor = self.sim.executor       # spun by another thread: requests go through it (on_executor)
        sent = _wait(on_executor(executor, lambda: action.send_goal_async(goal, feedback_callback=on_feedback)),
                     timeout, "executor task")
        handle = _wait(sent, timeout, "goal response")
        if not handle.accepted:
            raise RuntimeError("the controller rejected the goal")
        result_future = _wait(on_executor(executor, handle.get_result_async), timeout, "executor task")
        while not started.wait(0.05):
            if result_future.done():      # refused at planning time: aborted with its reason, no feedback
                res = result_future.result()
                return res.status, res.result, feedback
        self.sim.step_received(steps, from_ns, step_ns)
        res = _wait(result_future, timeout, "goal result")
        return res.status, res.result, feedback


def _wait(future: Any, timeout: float, what: str) -> Any:
    if not wait_done(future, timeout):
        raise RuntimeError(f"no {what} from the controller within {timeout:g} s")
    return future.result()


def _end_effector(record: JointRecord, L: float) -> np.ndarray:
    return np.array(end_effector_of(record.position[:3], L))


def _steps(seconds: float, step_ns: int) -> int:
    return math.ceil(round(seconds * NS_PER_S) / step_ns)


def run_moves(ctl: ControllerClient, step_ns: int, *, L: float = PAPER_PARAMS.L,
              ) -> tuple[list[MoveReport], TrajectoryReport, list[JointRecord]]:
    """From rest with the clock at 0: the waypoint moves, then the trajectory. Returns
    ``(move reports, trajectory report, joint states received)``."""
    from builtin_interfaces.msg import Duration
    from tensegrity_msgs.msg import JointTolerance
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    sim = ctl.sim
    sim.set_law(None)                  # the controller answers every step, not this client
    sim.take_joints()
    sim.reset_all()
    now = 0
    ctl.wait_answered(now)
    rest = forward_kinematics(0.7, 0.7, PAPER_PARAMS)
    move_steps = _steps(MOVE_TIME + max(SETTLE_TIMEOUT + SETTLE_WINDOW, CHECK_AFTER), step_ns) + 1
    moves = []
    for dx, dy in WAYPOINT_OFFSETS:
        target = (rest.x + dx, rest.y + dy)
        start = sim.wait_joint(now)               # the goal starts here (the state the controller holds)
        goal = ctl.Move.Goal(x=target[0], y=target[1], duration=MOVE_TIME, goal_tolerance=GOAL_TOLERANCE)
        _, res, _ = ctl.run_goal(ctl.move, goal, move_steps, now, step_ns)
        later_ns = now + round((MOVE_TIME + CHECK_AFTER) * NS_PER_S)
        sim.wait_joint(later_ns)
        window = [j for j in sim.joints_since(now) if j.stamp_ns <= later_ns]
        now += move_steps * step_ns
        ctl.wait_answered(now)
        moves.append(_move_report(target, _end_effector(start, L), res, window, L))
    traj = JointTrajectory(joint_names=list(ACTUATED_JOINTS))
    for t, rho in TRAJECTORY:
        sec = math.floor(t)
        traj.points.append(JointTrajectoryPoint(positions=list(rho),
                                                time_from_start=Duration(sec=sec, nanosec=round((t - sec) * 1e9))))
    sec = math.floor(TRAJECTORY_GOAL_TIME)
    goal = ctl.Follow.Goal(trajectory=traj,
                           goal_tolerance=[JointTolerance(name=n, position=TRAJECTORY_TOLERANCE) for n in ACTUATED_JOINTS],
                           goal_time_tolerance=Duration(sec=sec, nanosec=round((TRAJECTORY_GOAL_TIME - sec) * 1e9)))
    traj_steps = _steps(TRAJECTORY[-1][0] + TRAJECTORY_GOAL_TIME + 0.1, step_ns)
    _, res, feedback = ctl.run_goal(ctl.follow, goal, traj_steps, now, step_ns)
    now += traj_steps * step_ns
    ctl.wait_answered(now)
    path = [max(abs(v) for v in f.error.positions) for f in feedback
            if f.error.time_from_start.sec + 1e-9 * f.error.time_from_start.nanosec < TRAJECTORY[-1][0]]
    trajectory = TrajectoryReport(int(res.error_code), res.error_string, tuple(res.final_error),
                                  float(res.end_effector_error), max(path, default=math.nan), float(res.max_force))
    sim.wait_joint(now)
    return moves, trajectory, sim.take_joints()


def _move_report(target: tuple[float, float], start: np.ndarray, res: Any, window: list[JointRecord],
                 L: float) -> MoveReport:
    """The report of a move from the joint states of its window (its start to CHECK_AFTER s
    after its end) and the action's result."""
    direction = np.asarray(target) - start
    unit = direction / max(float(np.hypot(*direction)), 1e-12)
    overshoot = max(float((_end_effector(j, L) - np.asarray(target)) @ unit) for j in window)
    return MoveReport(target, int(res.error_code), res.error_string, float(res.settled_error),
                      float(res.settling_time), float(res.max_force), max(0.0, overshoot),
                      float(np.hypot(*(_end_effector(window[-1], L) - np.asarray(target)))))
