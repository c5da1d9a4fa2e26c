"""``tensegrity_controller``: the class-2 mechanism's controller, with two actions.

Subscribes ``joint_states`` (rho1, rho2 [m], beta [rad]; positions and velocities) and, on
every new sample, publishes ``actuator_forces`` (tensegrity_msgs/ActuatorForces; positive
= tensile), stamped with the sample's time. A sample repeated unchanged (same stamp,
positions and velocities) gets the same command again and does not advance the law: a
client that lost the answer, or whose state never arrived (a volatile message sent before
discovery matched the two ends), asks again by publishing the state again. The law is the
core's :class:`~tensegrity_core.class2.control.TrackingController` (feedforward along the
goal's reference plus gain-scheduled LQR feedback; docs/control.md). When no goal runs it holds
the last reference (at start: rest where the first joint state finds the mechanism).

Actions (tensegrity_msgs/action):

- ``move_end_effector`` (MoveEndEffector): D to (x, y) along a straight line, IK along it;
- ``follow_actuator_trajectory`` (FollowActuatorTrajectory): a JointTrajectory of rho1, rho2.

A new goal of either action preempts the running one (aborted with ``PREEMPTED``); a
cancelled goal stops where its reference is and holds there. A goal that cannot be
planned (bad numbers, unknown joints, out of the workspace, through a singular set, over
the force budget) is accepted and aborted at once with its reason in the result
(``error_code``, ``error_string``: ROS 2's goal response has no field for a reason); the
running goal and the hold are not disturbed. A goal aborts with ``SIMULATOR_STOPPED`` when
the joint states' time has not advanced for ``state_timeout`` seconds of the controller's
watch (:mod:`.state_watch`; a goal before the first joint state waits that long for it) and
with ``SINGULAR_STATE`` when the measured state comes within ``singular_abort`` of the
lambda1/lambda2 sets.

Manual commands take over: a command on ``actuator_forces`` that this node did not send
(``tensegrity send-forces``, a script of one's own) makes the controller stop commanding,
says so once in its log, and ends a running goal (``PREEMPTED``, "a command on
actuator_forces from another node took over"); its next goal makes it command again. So
``up`` then ``send-forces`` moves the mechanism under the sent forces instead of a tug of
war with the hold.

Parameters: ``scene`` (the mechanism's parameters, shared with the simulator and the IK
node), ``rate`` (the sampling rate the gains are designed for: the simulator's
``publish_rate``), ``max_force``, ``force_budget``, tolerances and timeouts (declared
below with their units).
"""

from __future__ import annotations

import math
import sys
import time
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from geometry_msgs.msg import Point
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.task import Future
from sensor_msgs.msg import JointState
from tensegrity_msgs.action import FollowActuatorTrajectory, MoveEndEffector
from tensegrity_msgs.msg import ActuatorForces

from tensegrity_core.class2 import dynamics_singularity
from tensegrity_core.class2.control import PlanningError, TrackingController, plan_move
from tensegrity_core.class2.control import goals as G
from tensegrity_core.class2.control.law import ScheduledGains, Tick
from tensegrity_core.class2.control.reference import Reference
from tensegrity_core.class2.control.trajectory import MAX_DURATION, actuator_reference
from tensegrity_core.class2.names import ACTUATED_JOINTS, ACTUATORS
from tensegrity_core.class2.params import Class2Params
from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import clip, excerpt
from tensegrity_core.sim.joint_trajectory import tolerance
from tensegrity_core.sim.scene.spec import Class2ModelSpec
from tensegrity_ros.nodes.common import declare, spin_node
from tensegrity_ros.nodes.controller_messages import (
    FOLLOW_PLANNING_CODES,
    MOVE_PLANNING_CODES,
    FloatArray,
    Goal,
    JointSample,
    OldStampError,
    far_start_warning,
    feedback,
    finish,
    given,
    joint_tolerances,
    parse_joint_state,
    stamp_start,
    start_feedback,
)
from tensegrity_ros.nodes.scene_param import declare_scene
from tensegrity_ros.nodes.state_watch import WATCH_PERIOD, StateWatch
from tensegrity_ros.rclpy_utils.messages import duration_to_s
from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services
from tensegrity_ros.rclpy_utils.raw_take import take_all, take_waiting

_MOVE = MoveEndEffector.Result
_FOLLOW = FollowActuatorTrajectory.Result


class _Job:
    """A running goal: its handle, the core's supervisor, and the future its execute awaits."""

    def __init__(self, handle: Any, goal: Goal) -> None:
        self.handle = handle                # rclpy's ServerGoalHandle
        self.goal = goal
        self.finished = Future()            # done once the goal has ended (its outcome)
        self.last_tick: Tick | None = None
        self.last_state: JointSample | None = None

    def end(self, outcome: G.Outcome) -> None:
        if not self.finished.done():
            self.finished.set_result(self.goal.end(outcome))


class ControllerNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("tensegrity_controller", **kwargs)
        guard_parameter_services(self)
        self.scene_name, scene = declare_scene(self)
        assert isinstance(scene.model, Class2ModelSpec)     # declare_scene refused any other
        self.params: Class2Params = scene.model.params
        rate = declare(self, "rate", 100.0, "sampling rate the gains are designed for [Hz]: the simulator's "
                       "publish_rate", lo=1.0, hi=10000.0, read_only=True)
        self.max_force = declare(self, "max_force", 5.0, "actuator force limit, |f1|, |f2| <= max_force [N]",
                                 lo=1e-6, read_only=True)
        self.force_budget = declare(self, "force_budget", 0.8, "share of max_force a goal's feedforward may "
                                    "use (the rest is the feedback's room) [fraction of max_force]", lo=0.01, hi=1.0, read_only=True)
        self.goal_tolerance = declare(self, "goal_tolerance", 1e-4, "default goal tolerance: of D for "
                                      "move_end_effector, of each length for follow_actuator_trajectory [m]",
                                      lo=1e-9, read_only=True)
        self.path_tolerance = declare(self, "path_tolerance", 0.0, "default path tolerance of each length "
                                      "during a trajectory [m]; 0 = not checked", lo=0.0, read_only=True)
        self.goal_time_tolerance = declare(self, "goal_time_tolerance", G.GOAL_TIME_TOLERANCE, "default time "
                                           "after a trajectory's last point to meet the goal tolerance [s]",
                                           lo=0.0, read_only=True)
        self.max_speed = declare(self, "max_speed", 0.05, "peak speed limit of D of a move_end_effector goal "
                                 "that gives neither a duration nor a max_speed (both 0) [m/s]", lo=1e-6, read_only=True)
        self.settle_timeout = declare(self, "settle_timeout", 5.0, "time after a move's end to come within "
                                      "its goal tolerance [s]", lo=0.0, read_only=True)
        self.settle_window = declare(self, "settle_window", 0.2, "how long D must stay within the goal "
                                     "tolerance for a move to succeed [s]", lo=0.0, read_only=True)
        self.state_timeout = declare(self, "state_timeout", 0.5, "a goal aborts when the joint states' time "
                                     "has not advanced for this long [s, of the controller's watch: wall "
                                     "time while it runs]", lo=0.01, read_only=True)
        self.singular_abort = declare(self, "singular_abort", 0.01, "a goal aborts when lambda1/L or "
                                      "lambda2/L of the measured state falls below this [fraction of L]", lo=0.0, hi=1.0,
                                      read_only=True)
        self.singular_margin = declare(self, "singular_margin", 0.02, "planned paths keep this distance "
                                       "from every singular set [L]", lo=0.0, hi=1.0, read_only=True)
        self.ctrl = TrackingController(self.params, dt=1.0 / rate, max_force=self.max_force)
        # Threads: every callback of this node runs on one executor thread (the control loop,
        # the watchdog and the goals' execute coroutines), so the state below needs no lock.
        # Planning a goal (tens of ms) runs on one planning thread on copies of the state
        # and is awaited, so the loop goes on holding or tracking meanwhile; one thread
        # keeps goals in the order they arrived. (rclpy's MultiThreadedExecutor is not used:
        # in Jazzy it re-submits tasks waiting in its pool and spun at 80 % CPU, 75 ms per
        # lockstep step, in the demo.)
        self._planner = ThreadPoolExecutor(max_workers=1, thread_name_prefix="planner")
        self._job: _Job | None = None
        self._latest: JointSample | None = None     # the last new joint state
        self._latest_header: Any = None      # its header (stamp and frame)
        self._answer: bytes | None = None    # the command published for it, serialized (sent again for a repeat)
        self._watch = StateWatch(WATCH_PERIOD)   # the silence since the last new joint state or goal start
        self._sent: deque[bytes] = deque(maxlen=256)   # the commands this node published lately, serialized
        self._manual = False                 # another node's command took over; until the next goal
        self._first_state: list[Future] = []   # goals that came before the first joint state
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)   # their wait is wall time

        # a history a briefly stalled recorder can be repaired from (the simulator's depth)
        self.pub = self.create_publisher(ActuatorForces, "actuator_forces", 1000)
        # every command on the topic, to tell another node's (a manual command) from this one's: taken
        # at each joint state and watchdog tick from a node no executor spins (an executor's wake-up
        # per command, mostly this node's own, cost ~0.5 ms of its CPU per step), compared serialized
        self._commands_node = Node(f"_{self.get_name()}_commands", namespace=self.get_namespace(),
                                   context=self.context, use_global_arguments=False, start_parameter_services=False,
                                   enable_rosout=False)
        self._commands = self._commands_node.create_subscription(
            ActuatorForces, self.resolve_topic_name("actuator_forces"), lambda _raw: None, QoSProfile(depth=10),
            raw=True)
        # latest state wins: a controller that fell behind acts on the newest sample, never a backlog
        self._joint_states = self.create_subscription(JointState, "joint_states", self.on_joints, QoSProfile(depth=1))
        self.create_timer(WATCH_PERIOD, self._watch_time)
        for action, name, execute in ((MoveEndEffector, "move_end_effector", self._execute_move),
                                      (FollowActuatorTrajectory, "follow_actuator_trajectory", self._execute_follow)):
            # feedback goes out on every tick: a history of 100 (1 s at 100 Hz) instead of
            # rclpy's 10 keeps every one for a client that falls behind on a loaded machine
            ActionServer(self, action, name, execute, feedback_pub_qos_profile=QoSProfile(depth=100),
                         goal_callback=lambda _req: GoalResponse.ACCEPT,
                         cancel_callback=lambda _handle: CancelResponse.ACCEPT)
        self.get_logger().info(f"controller ready (scene {self.scene_name!r}, {rate:g} Hz, max_force "
                               f"{self.max_force:g} N)")

    # -- the control loop ----------------------------------------------------------------
    def on_joints(self, msg: JointState) -> None:
        self._read_commands()                # another node's command that came before this state counts first
        state = parse_joint_state(msg)
        if state is None:
            self.get_logger().warning("joint_states without finite rho1, rho2, beta positions and velocities "
                                      "ignored", throttle_duration_sec=2.0)
            return
        t, q, qdot = state
        if self._latest is not None and t <= self._latest[0]:
            t0, q0, qdot0 = self._latest
            if t == t0 and np.array_equal(q, q0) and np.array_equal(qdot, qdot0):
                # not a new sample (a paused simulator repeats it, a client re-publishes it when
                # the answer did not come): the same answer again, the controller not advanced
                if self._answer is not None and not self._manual:
                    self._publish(self._answer)
                return
            self._simulation_reset(t)       # time went back, or another state at the same time
        self._latest = state
        self._latest_header = msg.header
        self._answer = None
        self._watch.heard(time.monotonic())
        if self.ctrl.reference is None and not self._start_holding(t, q):
            return
        for waiting in self._first_state:
            if not waiting.done():
                waiting.set_result(True)
        if self._manual:
            return                          # another node commands: nothing sent until the next goal
        tick = self.ctrl.update(t, q, qdot)
        job = self._job
        if job is not None:
            self._supervise(job, t, q, qdot, tick)
        cmd = ActuatorForces(name=list(ACTUATORS), force=[float(tick.forces[0]), float(tick.forces[1])])
        cmd.header.stamp = msg.header.stamp
        self._answer = self._publish(cmd)
        if job is not None and not job.finished.done():
            job.handle.publish_feedback(feedback(job.goal, msg.header, tick, q, qdot))

    def _publish(self, cmd: ActuatorForces | bytes) -> bytes:
        """Publish ``cmd`` (a message, or one serialized) as this node's; returns it serialized."""
        raw = cmd if isinstance(cmd, bytes) else serialize_message(cmd)
        self._sent.append(raw)
        self.pub.publish(raw)
        return raw

    def _read_commands(self) -> None:
        """Take the commands that came on actuator_forces: another node's takes over (see the
        module docstring)."""
        for raw, _info in take_all(self._commands):
            if not self._manual and raw not in self._sent:
                self._on_command_seen(deserialize_message(raw, ActuatorForces))

    def _on_command_seen(self, msg: ActuatorForces) -> None:
        """Another node's command on actuator_forces: it takes over."""
        self._manual = True
        forces = excerpt([float(f) for f in msg.force])
        self.get_logger().warning(clip(f"another node commands actuator_forces ({forces} N): the controller stops "
                                       "commanding until its next goal"))
        job = self._job
        if job is not None:
            if self._latest is not None:
                self.ctrl.hold_here(self._latest[0])
            self._end(job, G.Outcome(G.PREEMPTED, "a command on actuator_forces from another node took over"))

    def _simulation_reset(self, t: float) -> None:
        """The simulation was reset: a joint state at ``t`` [s] that is not a repeat of the
        latest and not later than it. The running goal ends, the integral is cleared and
        the controller holds where it finds the mechanism now. A repeat (same
        stamp, same positions and velocities) is not a reset: a lockstep simulator keeps
        its command for a state it publishes again unchanged."""
        assert self._latest is not None         # a reset is seen against the latest state
        before = self._latest[0]
        what = f"its time went back from {before:.3f} s to {t:.3f} s" if t < before else f"its state changed at {t:.3f} s"
        job = self._job
        if job is not None:
            self._end(job, G.Outcome(G.SIMULATOR_STOPPED, f"the simulation was reset: {what}"))
        self.ctrl.reference = None
        self.ctrl.reset_integral()
        self.get_logger().info(f"the simulation was reset ({what}): holding anew")

    def _start_holding(self, t: float, q: FloatArray) -> bool:
        try:
            self.ctrl.hold(float(q[0]), float(q[1]), t)
        except TensegrityError as err:
            self.get_logger().error(f"cannot hold the measured configuration: {err}", throttle_duration_sec=2.0)
            return False
        self.get_logger().info(f"holding rho = ({q[0]:.4f}, {q[1]:.4f}) m")
        return True

    def _supervise(self, job: _Job, t: float, q: FloatArray, qdot: FloatArray, tick: Tick) -> None:
        job.last_tick, job.last_state = tick, (t, q, qdot)
        if job.handle.is_cancel_requested:
            self.ctrl.hold_here(t)
            return self._end(job, G.Outcome(G.CANCELED, "cancelled: holding where the reference was"))
        name, lam = dynamics_singularity(float(q[0]), float(q[1]), self.params)
        if lam < self.singular_abort:
            self.ctrl.hold_here(t)
            return self._end(job, G.Outcome(G.SINGULAR_STATE, f"the measured state is at {name}/L = {lam:.3g} "
                                            f"(below {self.singular_abort:g}): rho = ({q[0]:.4f}, {q[1]:.4f}) m"))
        if isinstance(job.goal, G.MoveGoal):
            outcome = job.goal.step(t, tick)
        else:
            outcome = job.goal.step(t, q, qdot, tick)
        if outcome is not None:
            if not outcome.succeeded:
                self.ctrl.hold_here(t)
            self._end(job, outcome)

    def _end(self, job: _Job, outcome: G.Outcome) -> None:
        job.end(outcome)
        if self._job is job:
            self._job = None

    def _watch_time(self) -> None:
        """The state watchdog (:class:`StateWatch`): a goal cannot wait for a simulator that has
        stopped; a state waiting in the reader is heard first. A goal sent to a paused simulator
        gets ``state_timeout`` for it to resume. Takes the commands too: another node's is seen
        while no joint state comes."""
        for msg in take_waiting(self._joint_states):
            self.on_joints(msg)
        self._read_commands()
        silence = self._watch.look(time.monotonic())
        job = self._job
        if job is None:
            return
        if silence > self.state_timeout:
            last = "none received" if self._latest is None else f"the last at t = {self._latest[0]:.3f} s"
            self._end(job, G.Outcome(G.SIMULATOR_STOPPED, f"the joint states' time has not advanced for "
                                     f"{silence:.2f} s of the controller's watch ({last}): the simulator "
                                     "stopped or is gone"))

    # -- goals ---------------------------------------------------------------------------
    async def _execute_move(self, handle: Any) -> Any:
        req = handle.request
        result = _MOVE()
        try:
            await self._until_first_state()
            q = self._require_state()[0]
            tol = self._tolerance(req.goal_tolerance, "goal_tolerance")
            duration, max_speed = given(req.duration), given(req.max_speed)
            if duration is None and max_speed is None:      # 0 = the controller's default, as goal_tolerance
                max_speed = self.max_speed
            ref, gains = await self._plan(lambda: plan_move(
                q, (req.x, req.y), self.params, duration=duration, max_speed=max_speed,
                force_budget=self.force_budget * self.max_force, singular_margin=self.singular_margin))
        except PlanningError as err:
            return self._refuse(handle, result, MOVE_PLANNING_CODES.get(err.code, _MOVE.INVALID_GOAL), str(err))
        except _NoState as err:
            return self._refuse(handle, result, _MOVE.SIMULATOR_STOPPED, str(err))
        goal = G.MoveGoal(ref, 0.0, tolerance=tol, settle_timeout=self.settle_timeout,
                          settle_window=self.settle_window)
        job = await self._run(handle, ref, gains, goal, None)
        tick = job.last_tick
        if tick is not None:
            result.end_effector = Point(x=float(tick.end_effector[0]), y=float(tick.end_effector[1]))
        result.settled_error = float(goal.distance)
        result.settling_time = float(goal.settling_time)
        result.max_force = float(goal.max_force)
        assert goal.outcome is not None                     # the job ends once its goal has
        return finish(handle, result, goal.outcome)

    async def _execute_follow(self, handle: Any) -> Any:
        req = handle.request
        result = _FOLLOW(joint_names=list(ACTUATED_JOINTS))
        traj = req.trajectory
        try:
            await self._until_first_state()
            q, qdot, now = self._require_state()
            if any(len(p.effort) for p in traj.points):
                raise PlanningError("points with effort are not accepted: the controller computes the forces")
            start = stamp_start(traj.header.stamp, now, [duration_to_s(p.time_from_start) for p in traj.points])
            if (far := far_start_warning(start, now, MAX_DURATION)) is not None:
                self.get_logger().warning(far)
            path = joint_tolerances(req.path_tolerance, self.path_tolerance)
            goal_tol = joint_tolerances(req.goal_tolerance, self.goal_tolerance)
            # control_msgs' reading, as for tolerances: 0 the default, < 0 (its -1) no limit
            goal_time = tolerance(duration_to_s(req.goal_time_tolerance), self.goal_time_tolerance)
            ref, gains = await self._plan(lambda: actuator_reference(
                traj.joint_names, [duration_to_s(p.time_from_start) for p in traj.points],
                [list(p.positions) for p in traj.points], [list(p.velocities) for p in traj.points],
                [list(p.accelerations) for p in traj.points], start_rho=q[:2], start_rate=qdot[:2],
                params=self.params, singular_margin=self.singular_margin,
                force_budget=self.force_budget * self.max_force))
        except PlanningError as err:
            return self._refuse(handle, result, FOLLOW_PLANNING_CODES.get(err.code, _FOLLOW.INVALID_GOAL), str(err))
        except OldStampError as err:
            return self._refuse(handle, result, _FOLLOW.OLD_HEADER_TIMESTAMP, str(err))
        except _NoState as err:
            return self._refuse(handle, result, _FOLLOW.SIMULATOR_STOPPED, str(err))
        goal = G.TrajectoryGoal(ref, 0.0, path_position=path[0], path_velocity=path[1],
                                goal_position=goal_tol[0], goal_velocity=goal_tol[1], goal_time=goal_time)
        job = await self._run(handle, ref, gains, goal, start)
        final = ref.final()
        if job.last_state is not None:
            t, q, _ = job.last_state
            result.final_error = [float(q[0] - final.q[0]), float(q[1] - final.q[1])]
            assert job.last_tick is not None                # set with last_state
            result.end_effector_error = float(math.hypot(*(job.last_tick.end_effector - final.end_effector)))
        result.max_force = float(goal.max_force)
        assert goal.outcome is not None                     # the job ends once its goal has
        return finish(handle, result, goal.outcome)

    async def _until_first_state(self) -> None:
        """Hold a goal that came before the first joint state (a client may send one as soon
        as the action server is up, before the simulator's first sample has arrived) until that
        state, at most ``state_timeout`` s of wall time; :meth:`_require_state` then refuses."""
        if self._latest is not None and self.ctrl.reference is not None:
            return
        arrived = Future()
        self._first_state.append(arrived)
        timer = self.create_timer(self.state_timeout, lambda: arrived.done() or arrived.set_result(False),
                                  clock=self._steady)
        try:
            await arrived
        finally:
            self.destroy_timer(timer)
            self._first_state.remove(arrived)

    def _require_state(self) -> tuple[FloatArray, FloatArray, float]:
        if self._latest is None or self.ctrl.reference is None:
            raise _NoState(f"no joint_states received within state_timeout = {self.state_timeout:g} s: "
                           "is the simulator running?")
        t, q, qdot = self._latest
        return q, qdot, t

    async def _plan(self, make_reference: Callable[[], Reference]) -> tuple[Reference, ScheduledGains]:
        """``(reference, gains)``: ``make_reference()`` and the gain schedule along it, on the
        planning thread (the costly part of a goal: tens of ms), awaited here."""
        planned = Future()
        executor = self.executor
        assert executor is not None                 # a goal runs on the node's executor

        def plan() -> None:
            try:
                ref = make_reference()
                planned.set_result((ref, self.ctrl.schedule(ref)))
            except Exception as err:        # re-raised by the await below
                planned.set_exception(err)
            try:
                executor.wake()             # the awaiting coroutine runs when the executor wakes
            except InvalidHandle:
                pass                        # the node is shutting down: nobody awaits any more

        self._planner.submit(plan)
        planned_reference: tuple[Reference, ScheduledGains] = await planned
        return planned_reference

    async def _run(self, handle: Any, ref: Reference, gains: ScheduledGains, goal: Goal, start: float | None) -> _Job:
        """Make ``goal`` the running one (preempting the last), then wait until it ends."""
        job = _Job(handle, goal)
        old = self._job
        assert self._latest is not None             # _require_state let the goal through
        t0 = self._latest[0] if start is None else start
        goal.t_start = t0
        if self._manual:
            self._manual = False
            self.ctrl.reset_integral()
            self.get_logger().info("a new goal: the controller commands actuator_forces again")
        self._job = job
        self._watch.heard(time.monotonic())
        self.ctrl.follow(ref, t0, gains)
        if old is not None:
            old.end(G.Outcome(G.PREEMPTED, "preempted by a newer goal"))
        assert self._latest is not None             # a goal starts on a measured state
        job.handle.publish_feedback(start_feedback(job.goal, self._latest_header, self._latest, self.params.L))
        await job.finished
        return job

    def _refuse(self, handle: Any, result: Any, code: int, reason: str) -> Any:
        self.get_logger().warning(f"goal refused: {reason}")
        result.error_code, result.error_string = code, reason
        handle.abort()
        return result

    def _tolerance(self, value: float, name: str) -> float:
        if not math.isfinite(value):
            raise PlanningError(f"{name} must be a finite number, got {value!r}")
        return self.goal_tolerance if value == 0.0 else (value if value > 0.0 else math.inf)

    def destroy_node(self) -> None:
        job, self._job = self._job, None
        if job is not None:
            job.end(G.Outcome(G.SIMULATOR_STOPPED, "the controller is shutting down"))
        self._planner.shutdown(wait=True, cancel_futures=True)
        self._commands_node.destroy_node()
        super().destroy_node()  # type: ignore[no-untyped-call]  # rclpy's, through super(): not excluded by name


class _NoState(TensegrityError):
    """No joint state yet: nothing to plan from."""


def main(argv: Sequence[str] | None = None) -> int:
    from threadpoolctl import threadpool_limits

    # The law's matrices are 8 x 8: a multi-threaded BLAS only adds hand-over costs (5x slower
    # gain design measured on a loaded 2-core machine), and it competes with the control loop.
    threadpool_limits(1)
    return spin_node(ControllerNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
