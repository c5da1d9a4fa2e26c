"""``tensegrity_cable_controller``: joint_trajectory_controller's action for actuated cables.

Serves ``~/follow_joint_trajectory`` (control_msgs/action/FollowJointTrajectory, the
definition of control_msgs' Jazzy release built from ``msgs_spec/control_msgs``), so that a
client written for ros2_control's joint_trajectory_controller works unchanged. The joints
are the scene's actuated cables that take commands; their positions are rest lengths [m]
(the motors' position command). The trajectory logic is the core's
(:mod:`tensegrity_core.sim.joint_trajectory`); this node translates messages.

- Active: once it has a joint state and a cable state naming every commanded cable (the
  two topics match separately), the controller is active, as a joint_trajectory_controller
  is once it has its state interfaces: only then does it answer joint states, so a client
  that waits for its first answer knows it takes goals. A goal that comes before is held
  until then, at most ``state_timeout`` seconds of wall time, and then refused INVALID_GOAL
  naming what did not come.
- Commands: every ``joint_states`` sample is answered with a ``CableCommand``
  (``cable_commands``) stamped like it, so that a lockstep simulator steps on (the joint
  state the controller became active on too, when it came first): while a goal
  runs, with the goal's joints at the trajectory's positions ``t - t_start`` after its
  start; idle, with an empty command, which changes nothing (the simulator holds the last
  rest lengths, as a motor holds its position, and a manual command on ``cable_commands``
  lasts). A sample repeated unchanged gets the same answer again (a lockstep simulator
  republishes a state whose answer it lacks).
- Checks and feedback: on every ``cable_states`` (the simulator's ``state_rate``) stamped no earlier than
  the goal was taken (the latest joint state's time: as joint_trajectory_controller's updates after a goal
  came; an older one a reader was behind with is not the goal's) the goal's joints' rest lengths as the
  simulator reports them are the actual positions, their tensions the actual efforts; feedback ``desired``
  / ``actual`` / ``error`` (positions, and the desired velocities and accelerations), path tolerance until
  the last point's time, goal tolerance after it within ``goal_time_tolerance`` (0: the default; < 0,
  control_msgs' -1: no limit, the goal waits for its tolerance). Rates of rest lengths are not measured:
  velocity tolerances are accepted and not checked.
- State: once active, every ``cable_states`` is also published as a
  ``JointTrajectoryControllerState`` on ``~/controller_state`` (joint_trajectory_controller's
  topic, published there every update): all the controller's joints in its order;
  ``feedback`` the reported rest lengths (effort: tensions), ``reference`` the trajectory's
  sample for a running goal's joints and the held rest length for the others, ``output`` the
  rest lengths commanded, ``error`` = reference - feedback (positions). The held rest length
  is what the simulator holds: the latest rest length commanded on ``cable_commands``, by this
  controller or by anyone else (a command the simulator refuses changes nothing: the same
  check, :func:`~tensegrity_ros.nodes.sim.cable_commands.parse_cable_command`), in the order
  they arrive, else the rest length the controller became active on (a lockstep simulator
  merges the commands for one step in the same order: :mod:`~tensegrity_ros.nodes.sim.lockstep`).
- Topic: a ``trajectory_msgs/JointTrajectory`` on ``~/joint_trajectory``
  (joint_trajectory_controller's topic interface) is a goal without an action: the default
  tolerances, no feedback and no result (a refusal or a violated tolerance is logged); it
  takes over from the running goal as a new goal does.
- Start: ``trajectory.header.stamp`` zero starts the goal at the latest joint state's time
  (the time it was accepted), a stamp starts it at that simulation time; a trajectory that
  ended before the latest joint state is OLD_HEADER_TIMESTAMP; one that starts more than a day
  of simulation time ahead waits for it, with a warning (a wall-clock stamp). The first
  segment starts from the current rest lengths unless the first point is at 0.
- A new goal takes over from the running one, which ends ABORTED with INVALID_GOAL "preempted: a
  newer goal took over" (joint_trajectory_controller's status, code and reason since its Jazzy
  release 4.41; CANCELED before); a cancelled goal ends CANCELED with SUCCESSFUL and the cables hold
  where they are. Goals follow simulation time: a paused simulator pauses them (a cancel still ends
  them at once; it republishes its state, at ``paused_publish_rate``). A running goal ends ABORTED
  with INVALID_GOAL when no joint state at all has come for ``state_timeout`` s of the controller's
  watch (:mod:`.state_watch`: its own stalls do not count): the simulator stopped or is gone, and a
  goal without a goal time would otherwise never end.

Parameters: ``scene`` (the simulator's: which cables there are), the default tolerances
``goal_tolerance`` [m], ``path_tolerance`` [m] (0 = not checked) and
``goal_time_tolerance`` [s] (0 = no limit), and ``state_timeout`` [s] (how long a goal waits for the
controller to become active, and a running goal for the next joint state).
"""

from __future__ import annotations

import math
import sys
import time
from collections import deque
from collections.abc import Sequence
from typing import Any

from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTrajectoryControllerState
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.task import Future
from sensor_msgs.msg import JointState
from tensegrity_msgs.msg import CableCommand, CableStates
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import clip, excerpt
from tensegrity_core.sim import compile_scene
from tensegrity_core.sim import joint_trajectory as jt
from tensegrity_ros.nodes.actuator_commands import CommandError
from tensegrity_ros.nodes.cable_states import unusable_cable_states
from tensegrity_ros.nodes.common import ParameterValueError, declare, spin_node
from tensegrity_ros.nodes.scene_param import declare_scene
from tensegrity_ros.nodes.sim.cable_commands import parse_cable_command
from tensegrity_ros.nodes.state_watch import WATCH_PERIOD, StateWatch
from tensegrity_ros.rclpy_utils.messages import duration_msg, stamp_ns
from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services
from tensegrity_ros.rclpy_utils.raw_take import take_all, take_waiting

_RESULT = FollowJointTrajectory.Result
NS_PER_S = 1_000_000_000
#: The depth of the reader of ``cable_commands`` [messages], read at every ``cable_states``
#: (a lockstep simulator at 1,000 steps/s and ``state_rate`` 10 Hz: 100 between two),
COMMAND_DEPTH = 1000
#: and how many of its own commands the controller recognises there: more than that depth, so
#: that its own command is never taken for another's.
OWN_ECHOES = 2 * COMMAND_DEPTH


class _Job:
    """A running goal: its handle (None: from ``~/joint_trajectory``), trajectory, checks, start [s],
    the simulation time it was taken at [s] (the latest joint state's) and the future its execute awaits."""

    def __init__(self, handle: Any, trajectory: jt.JointTrajectory, monitor: jt.GoalMonitor, t_start: float,
                 t_taken: float) -> None:
        self.handle, self.trajectory, self.monitor = handle, trajectory, monitor
        self.t_start, self.t_taken, self.finished = t_start, t_taken, Future()

    def end(self, outcome: jt.Outcome, status: str) -> None:
        if not self.finished.done():
            self.finished.set_result((outcome, status))


class CableControllerNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("tensegrity_cable_controller", **kwargs)
        guard_parameter_services(self)
        self.scene_name, scene = declare_scene(self, class2_only=False)
        self.scene = scene
        try:
            self.interface = compile_scene(scene).interface
        except TensegrityError as err:
            raise ParameterValueError(clip(f"{self.get_name()}: cannot compile scene {excerpt(self.scene_name)}: {err}")) \
                from None
        if self.interface.command != "rest_length" or not any(self.interface.commanded):
            raise ParameterValueError(f"{self.get_name()}: scene {excerpt(self.scene_name)} has no actuated cables that take "
                             "commands: this node drives the actuated cables of general structures and robots")
        self.goal_tolerance = declare(self, "goal_tolerance", 1e-4, "default goal tolerance of each cable's rest "
                                      "length [m]", lo=1e-12, read_only=True)
        self.path_tolerance = declare(self, "path_tolerance", 0.0, "default path tolerance of each cable's rest "
                                      "length while a trajectory runs [m]; 0 = not checked", lo=0.0, read_only=True)
        self.goal_time_tolerance = declare(self, "goal_time_tolerance", 1.0, "default time after a trajectory's "
                                           "last point to meet the goal tolerance, plus for a robot the time its "
                                           "motors of the goal need to close a gap as wide as their range; 0 = no "
                                           "limit (as joint_trajectory_controller's constraints.goal_time) [s]",
                                           lo=0.0, read_only=True)
        self.state_timeout = declare(self, "state_timeout", 10.0, "how long a goal sent before the controller "
                                     "has the simulator's joint_states and cable_states waits for them [s of wall "
                                     "time], then refused, and a running goal for the next joint state [s of the "
                                     "controller's watch], then aborted", lo=0.0, read_only=True)
        #: the controller's joints: the commanded inputs (cables) in the scene's order
        self.joints = [n for n, c in zip(self.interface.inputs, self.interface.commanded) if c]
        self._column = {n: i for i, n in enumerate(self.joints)}
        self._job: _Job | None = None
        self._latest: tuple[int, float] | None = None   # (stamp [ns], t [s]) of the latest joint state
        self._latest_header: Any = None                 # its header (answered once the controller is active)
        self._answer: bytes | None = None                # the answer to it, serialized
        self._rest: dict[str, float] = {}                # each cable's rest length [m], from cable_states
        self._held: dict[str, float] = {}                # each joint's held rest length [m] (controller_state)
        self._sent: deque[bytes] = deque()               # the latest commands it sent, serialized,
        self._sent_count: dict[bytes, int] = {}          # and how often each is in there
        self._position = {n for n, m in zip(self.interface.inputs, self.interface.modes or
                                            ("rest_length",) * len(self.interface.inputs)) if m == "rest_length"}
        self._active = False                             # both states received: it answers and takes goals
        self._waiting: dict[bytes, Future] = {}          # goals waiting for that, by goal id: how it ended
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._watch = StateWatch(WATCH_PERIOD)           # the silence since the last joint state or goal start
        # a history a briefly stalled recorder can be repaired from (the simulator's depth)
        self.pub = self.create_publisher(CableCommand, "cable_commands", QoSProfile(depth=1000))
        self._joint_states = self.create_subscription(JointState, "joint_states", self.on_joints, QoSProfile(depth=1))
        self.create_timer(WATCH_PERIOD, self._watch_states, clock=self._steady)
        # the simulator's depth: a briefly stalled controller still answers every state
        self.create_subscription(CableStates, "cable_states", self.on_cables, QoSProfile(depth=100))
        # every command the simulator takes, others' too: what the cables hold (controller_state).
        # Read in bulk at each cable_states by a node no executor spins: a callback per command
        # (one per simulator step, mostly this controller's own) cost 0.2-0.3 ms of CPU each
        self._commands_node = Node(f"_{self.get_name()}_commands", namespace=self.get_namespace(),
                                   context=self.context, use_global_arguments=False, start_parameter_services=False,
                                   enable_rosout=False)
        self._commands = self._commands_node.create_subscription(
            CableCommand, self.resolve_topic_name("cable_commands"), lambda _raw: None,
            QoSProfile(depth=COMMAND_DEPTH), raw=True)
        # joint_trajectory_controller's publisher: reliable, volatile, keep last (system default)
        self.state_pub = self.create_publisher(JointTrajectoryControllerState, "~/controller_state",
                                               QoSProfile(depth=10))
        self.create_subscription(JointTrajectory, "~/joint_trajectory", self.on_trajectory, QoSProfile(depth=1))
        ActionServer(self, FollowJointTrajectory, "~/follow_joint_trajectory", self._execute,
                     goal_callback=lambda _req: GoalResponse.ACCEPT,
                     cancel_callback=self._on_cancel, feedback_pub_qos_profile=QoSProfile(depth=100))
        self.get_logger().info(f"cable controller ready (scene {self.scene_name!r}: {', '.join(self.joints)})")

    # -- commands and checks ---------------------------------------------------------------
    def on_joints(self, msg: JointState) -> None:
        self._watch.heard(time.monotonic())      # any state: the simulator is there (paused, it repeats one)
        stamp = stamp_ns(msg.header.stamp)
        if self._latest is not None and stamp < self._latest[0] and self._job is not None:   # reset: docs/ros.md
            self._end(self._job, jt.Outcome(jt.INVALID_GOAL, f"the simulation was reset: its time went back from "
                      f"{self._latest[1]:g} s to {stamp / NS_PER_S:g} s; the cables hold the rest lengths the reset "
                      "gave them"), "aborted")
        if self._latest is None or stamp != self._latest[0]:
            self._latest, self._latest_header, self._answer = (stamp, stamp / NS_PER_S), msg.header, None
        if self._active:
            self._reply()
        elif self._rest:
            self._activate()     # cable_states came first

    def _reply(self) -> None:
        """Answer the latest joint state (a state sent again gets the same answer again)."""
        if self._answer is None:
            job, header, latest = self._job, self._latest_header, self._latest
            assert latest is not None    # active: a joint state came
            if job is None:
                answer = CableCommand(header=header)       # idle: no change
            else:
                tr = job.trajectory
                command = tr.command(latest[1] - job.t_start, self._rest_lengths())
                answer = CableCommand(header=header, name=list(tr.names), rest_length=[command[i] for i in tr.inputs])
                self._held.update(zip(answer.name, answer.rest_length))
            self._answer = serialize_message(answer)
        self._remember(self._answer)
        self.pub.publish(self._answer)

    def _remember(self, raw: bytes) -> None:
        """Keep the latest :data:`OWN_ECHOES` commands sent, to know them on ``cable_commands``."""
        self._sent.append(raw)
        self._sent_count[raw] = self._sent_count.get(raw, 0) + 1
        if len(self._sent) > OWN_ECHOES:
            old = self._sent.popleft()
            if self._sent_count[old] == 1:
                del self._sent_count[old]
            else:
                self._sent_count[old] -= 1

    def _read_commands(self) -> None:
        """Take the commands that came on ``cable_commands``: the rest lengths each of another's
        sets, if the simulator takes it, are what the cables hold from then on (the
        controller's own were taken into account when sent)."""
        inputs = self.interface.inputs
        for raw, _info in take_all(self._commands):
            if raw in self._sent_count:
                continue
            msg = deserialize_message(raw, CableCommand)
            try:
                update = parse_cable_command(list(msg.name), msg.rest_length, msg.reel_speed, msg.tension,
                                             self.interface)
            except CommandError:
                continue                 # the simulator refuses it (and says why): nothing changes
            self._held.update((inputs[i], v) for i, v in zip(update.indices, update.values)
                              if inputs[i] in self._position and inputs[i] in self._column)

    def _missing(self) -> str:
        """What the controller lacks to be active ("" when nothing)."""
        missing = [n for n in self.interface.inputs if n not in self._rest]
        if self._latest is None:
            return "no joint_states " + ("and no cable_states " if missing else "") + "received"
        if len(missing) == len(self.interface.inputs):
            return "joint_states received but no cable_states"
        if missing:
            more = ", ..." if len(missing) > 3 else ""
            return f"cable_states received without the cables {', '.join(map(excerpt, missing[:3]))}{more}"
        return ""

    def _activate(self) -> None:
        """Become active once both states are there: release the held goals, answer the latest state."""
        if self._active or self._missing():
            return
        self._active = True
        self._held = {n: self._rest[n] for n in self.joints}
        take_all(self._commands)         # what came before is in these rest lengths already
        self.get_logger().info("active: joint_states and cable_states received")
        for ready in self._waiting.values():
            _settle(ready, "active")
        self._reply()

    def _rest_lengths(self) -> list[float]:
        """Every input's current rest length [m] (as the simulator last reported it)."""
        return [self._rest.get(n, math.nan) for n in self.interface.inputs]

    def on_cables(self, msg: CableStates) -> None:
        unusable = unusable_cable_states(msg)
        if unusable:
            self.get_logger().warning(f"cable_states ignored: {unusable}", throttle_duration_sec=2.0)
            return
        self._rest.update(zip(msg.name, msg.rest_length))
        if not self._active:
            self._activate()
        index = {n: i for i, n in enumerate(msg.name)}
        job = self._job
        t = stamp_ns(msg.header.stamp) / NS_PER_S
        tau = math.nan if job is None else t - job.t_start
        if job is not None and (job.finished.done() or not tau >= 0.0 or t < job.t_taken
                                or any(n not in index for n in job.trajectory.names)):
            job = None   # ended, not started, older than the goal (a reader behind) or without its cables
        if self._active and all(n in index for n in self.joints):
            self._read_commands()
            self.state_pub.publish(self._state(msg, index, job, tau))
        if job is None:
            return
        tr = job.trajectory
        actual = [float(msg.rest_length[index[n]]) for n in tr.names]
        desired = tr.sample(tau)
        when = duration_msg(tau)
        fb = FollowJointTrajectory.Feedback(header=msg.header, joint_names=list(tr.names))
        fb.desired = JointTrajectoryPoint(positions=desired.positions.tolist(),
                                          velocities=desired.velocities.tolist(),
                                          accelerations=desired.accelerations.tolist(), time_from_start=when)
        fb.actual = JointTrajectoryPoint(positions=actual, effort=[float(msg.tension[index[n]]) for n in tr.names],
                                         time_from_start=when)
        fb.error = JointTrajectoryPoint(positions=[d - a for d, a in zip(desired.positions.tolist(), actual)],
                                        time_from_start=when)
        if job.handle is not None:
            job.handle.publish_feedback(fb)
        outcome = job.monitor.check(tau, actual)
        if outcome is not None:
            if job.handle is None and not outcome.succeeded:
                self.get_logger().warning(clip(f"joint_trajectory: {outcome.message}"))
            self._end(job, outcome, "succeeded" if outcome.succeeded else "aborted")

    def _state(self, msg: CableStates, index: dict[str, int], job: _Job | None, tau: float) -> Any:
        """The ``controller_state`` of one ``cable_states`` sample: every joint, ``job``'s at its
        trajectory's sample ``tau`` [s] after its start, the others held."""
        reference, rates, accelerations = [self._held[n] for n in self.joints], [0.0] * len(self.joints), \
            [0.0] * len(self.joints)
        when = duration_msg(0.0)
        if job is not None:
            sample, when = job.trajectory.sample(tau), duration_msg(tau)
            for name, p, v, a in zip(job.trajectory.names, sample.positions.tolist(), sample.velocities.tolist(),
                                     sample.accelerations.tolist()):
                column = self._column[name]
                reference[column], rates[column], accelerations[column] = p, v, a
        feedback = [float(msg.rest_length[index[n]]) for n in self.joints]
        # as joint_trajectory_controller: feedback and error at time_from_start 0, no speed scaling
        return JointTrajectoryControllerState(
            header=msg.header, joint_names=list(self.joints), speed_scaling_factor=1.0,
            reference=JointTrajectoryPoint(positions=reference, velocities=rates, accelerations=accelerations,
                                           time_from_start=when),
            feedback=JointTrajectoryPoint(positions=feedback,
                                          effort=[float(msg.tension[index[n]]) for n in self.joints]),
            error=JointTrajectoryPoint(positions=[r - f for r, f in zip(reference, feedback)]),
            output=JointTrajectoryPoint(positions=list(reference)))

    def _end(self, job: _Job, outcome: jt.Outcome, status: str) -> None:
        job.end(outcome, status)
        if self._job is job:
            self._job = None

    # -- goals -------------------------------------------------------------------------------
    async def _execute(self, handle: Any) -> Any:
        req = handle.request
        result = _RESULT()
        try:
            held = "active" if self._active else await self._until_active(handle)
            if held == "cancelled":
                result.error_string = "cancelled before the controller was active"
                handle.canceled()
                return result
            if held == "shutdown":
                raise jt.TrajectoryError("the controller is shutting down")
            if held == "timeout":
                raise jt.TrajectoryError(f"not active after state_timeout = {self.state_timeout:g} s: "
                                         f"{self._missing()}: is the simulator running scene "
                                         f"{excerpt(self.scene_name)}?")
            job = self._plan(handle, req)
        except jt.TrajectoryError as err:
            self.get_logger().warning(clip(f"goal refused: {err}"))
            result.error_code, result.error_string = err.code, clip(str(err))
            handle.abort()
            return result
        self._take_over(job)
        outcome, status = await job.finished
        result.error_code, result.error_string = outcome.code, outcome.message
        {"succeeded": handle.succeed, "aborted": handle.abort, "canceled": handle.canceled}[status]()
        return result

    def _take_over(self, job: _Job) -> None:
        """Run ``job`` from now on; the running one ends preempted."""
        old, self._job, self._answer = self._job, job, None
        self._watch.heard(time.monotonic())
        if old is not None:
            self._end(old, jt.Outcome(jt.INVALID_GOAL, "preempted: a newer goal took over"), "aborted")

    def _watch_states(self) -> None:
        """A running goal ends when no joint state has come for ``state_timeout`` s of watch
        (:class:`StateWatch`; a state waiting in the reader is heard first)."""
        for msg in take_waiting(self._joint_states):
            self.on_joints(msg)
        silence, job = self._watch.look(time.monotonic()), self._job
        if job is not None and silence > self.state_timeout:
            self._end(job, jt.Outcome(jt.INVALID_GOAL, f"no joint_states for {silence:.2f} s of the controller's "
                                      "watch: the simulator stopped or is gone"), "aborted")

    def on_trajectory(self, msg: JointTrajectory) -> None:
        """joint_trajectory_controller's ``~/joint_trajectory``: a goal without an action (no
        feedback, no result; the default tolerances), taking over from the running one."""
        try:
            if not self._active:
                raise jt.TrajectoryError(f"the controller is not active: {self._missing()}")
            job = self._plan(None, FollowJointTrajectory.Goal(trajectory=msg))
        except jt.TrajectoryError as err:
            self.get_logger().warning(clip(f"joint_trajectory ignored: {err}"))
            return
        self._take_over(job)

    async def _until_active(self, handle: Any) -> str:
        """Hold a goal until the controller is active (``"active"``), at most
        ``state_timeout`` s of wall time (``"timeout"``), or until it is cancelled
        (``"cancelled"``) or the node shuts down (``"shutdown"``)."""
        if handle.is_cancel_requested:     # cancelled before its execution began
            return "cancelled"
        goal = bytes(handle.goal_id.uuid)
        ready = self._waiting[goal] = Future()
        timer = self.create_timer(self.state_timeout, lambda: _settle(ready, "timeout"), clock=self._steady)
        try:
            return str(await ready)
        finally:
            self.destroy_timer(timer)
            del self._waiting[goal]

    def _on_cancel(self, handle: Any) -> CancelResponse:
        held = self._waiting.get(bytes(handle.goal_id.uuid))
        if held is not None:
            _settle(held, "cancelled")
        job = self._job
        if job is not None and job.handle is handle:
            self._end(job, jt.Outcome(jt.SUCCESSFUL, "cancelled: the cables hold the rest lengths reached"),
                      "canceled")
        return CancelResponse.ACCEPT

    def _plan(self, handle: Any, req: Any) -> _Job:
        """The job of a goal, or :class:`~tensegrity_core.sim.joint_trajectory.TrajectoryError`."""
        traj, multi = req.trajectory, req.multi_dof_trajectory
        if why := jt.unsupported_reason(
                multi_dof=bool(len(multi.joint_names) or len(multi.points)), effort=any(len(p.effort) for p in traj.points),
                component_tolerances=(len(req.component_path_tolerance), len(req.component_goal_tolerance))):
            raise jt.TrajectoryError(why)
        trajectory = jt.plan_trajectory(
            list(traj.joint_names), [stamp_ns(p.time_from_start) / NS_PER_S for p in traj.points],
            [list(p.positions) for p in traj.points], [list(p.velocities) for p in traj.points],
            [list(p.accelerations) for p in traj.points], interface=self.interface, start=self._rest_lengths())
        assert self._latest is not None    # active: a joint state came
        now = self._latest[1]
        stamp = stamp_ns(traj.header.stamp)
        t_start = now if stamp == 0 else stamp / NS_PER_S
        if t_start + trajectory.duration < now:
            raise jt.TrajectoryError(f"the trajectory started at {t_start:.6f} s ended before the simulation's time "
                                     f"{now:.6f} s", code=jt.OLD_HEADER_TIMESTAMP)
        if t_start - now > jt.MAX_DURATION:
            # as joint_trajectory_controller it waits; said, since a wall-clock stamp from a
            # client without use_sim_time starts decades of simulation time ahead
            self.get_logger().warning(clip(
                f"a goal starts at {t_start:.6f} s, {t_start - now:.3g} s after the simulation's time {now:.6f} s, "
                "and waits until then: is its trajectory.header.stamp wall-clock time (a client without "
                "use_sim_time)? A zero stamp starts it at once"))
        n = len(trajectory.names)
        path, goal = [self.path_tolerance or math.inf] * n, [self.goal_tolerance] * n
        for items, bounds, default in ((req.path_tolerance, path, self.path_tolerance or math.inf),
                                       (req.goal_tolerance, goal, self.goal_tolerance)):
            for item in items:
                if item.name not in trajectory.names:
                    # as joint_trajectory_controller, tolerances may name any of the
                    # controller's joints: one the trajectory leaves out holds, nothing to check
                    if item.name in self.joints:
                        continue
                    raise jt.TrajectoryError(f"tolerance for unknown joint {excerpt(item.name)}; the joints are "
                                             f"{', '.join(self.joints)}", code=jt.INVALID_JOINTS)
                bounds[trajectory.names.index(item.name)] = jt.tolerance(item.position, default)
        # as joint_trajectory_controller: 0 the default, -1 (here any value < 0) no limit; a default of 0 is
        # no limit too (its constraints.goal_time); a robot's default adds its motors' time to arrive
        settle = jt.motors_settle_time(self.scene, trajectory.names, min(goal)) if math.isfinite(min(goal)) else 0.0
        default_goal_time = self.goal_time_tolerance + settle if self.goal_time_tolerance else math.inf
        goal_time = jt.tolerance(stamp_ns(req.goal_time_tolerance) / NS_PER_S, default_goal_time)
        off = (math.inf,) * n
        monitor = jt.GoalMonitor(trajectory, jt.Tolerances(tuple(path), off, tuple(goal), off, goal_time))
        return _Job(handle, trajectory, monitor, t_start, now)

    def destroy_node(self) -> None:
        for ready in self._waiting.values():
            _settle(ready, "shutdown")
        job, self._job = self._job, None
        if job is not None:
            job.end(jt.Outcome(jt.INVALID_GOAL, "the controller is shutting down"), "aborted")
        self._commands_node.destroy_node()
        super().destroy_node()  # type: ignore[no-untyped-call]  # rclpy's, through super(): not excluded by name


def _settle(future: Future, outcome: str) -> None:
    """End a held goal's wait with ``outcome`` unless it has ended."""
    if not future.done():
        future.set_result(outcome)


def main(argv: Sequence[str] | None = None) -> int:
    return spin_node(CableControllerNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))

