"""``tensegrity_sim``: the simulated mechanism or structure of any scene.

Commands (the model says which it takes, :class:`~tensegrity_core.sim.model.Interface`):
``actuator_forces`` (tensegrity_msgs/ActuatorForces; the class-2 mechanism; positive =
tensile, pulls the actuator's nodes together) or ``cable_commands``
(tensegrity_msgs/CableCommand; general structures and robots: rest lengths [m] of the
actuated cables, a robot's motors then reach them with their lag and slew limit).
Publishes, stamped with simulation time (topics per model: :mod:`.outputs`):

- ``joint_states`` (sensor_msgs/JointState): class-2 joints ``rho1``, ``rho2`` [m] and
  ``beta`` [rad] (effort = the applied actuator force [N], 0 for beta); general structures
  and robots one joint per actuated cable (position = length [m], velocity [m/s], effort =
  tension [N]; a robot's measured ones, :mod:`.joint_sensors`);
- ``end_effector`` (geometry_msgs/PointStamped): node D, or the scene's end-effector node [m];
- class-2: ``mechanism_state`` (tensegrity_msgs/MechanismState) at ``state_rate``;
- general and robots: ``cable_states`` (tensegrity_msgs/CableStates: every member) at
  ``state_rate``, ``body_states`` (tensegrity_msgs/RigidBodyStates; a robot's rods) and
  ``/tf`` (tf2_msgs/TFMessage: world -> each body's frame, ``frame_prefix`` + its name) every publication;
- robots: ``imu/<body>`` (sensor_msgs/Imu) at ``imu_rate``, ``contacts``
  (tensegrity_msgs/CapContacts) at ``state_rate``;
- ``markers`` (visualization_msgs/MarkerArray): members coloured by force (red tension,
  blue compression), nodes as spheres (robots: rods, cables, floor, contacts); at ``marker_rate``;
- ``events`` (tensegrity_msgs/SimulationEvent): what the integrator located, when it did;
- ``/clock`` (rosgraph_msgs/Clock): simulation time, so other nodes can use_sim_time.

Services: ``reset`` (std_srvs/Trigger: back to the initial state, the clock keeps
running forward) and the ``simulation_interfaces`` standard: ``get_simulator_features``,
``get_simulation_state``, ``set_simulation_state``, ``step_simulation``,
``reset_simulation``, and the action ``simulate_steps`` (:mod:`.interfaces`).

Time advances in whole steps of ``step_size``; ``/clock`` reads exactly ``k * step_size``
(integer nanoseconds) after ``k`` steps. The run states and their transitions are
:mod:`.control`; the time policy is plain logic in its own modules: the free-running tick
schedule (:mod:`.schedule`: real-time factor, no catch-up bursts), the lockstep pacer
(:mod:`.pacer`) and gate (:mod:`.lockstep`: the command of the step waited at), the command
hold and its timeout (:mod:`.hold`), which slower topics go out with a publication
(:mod:`.decimation`). The node keeps the entities, the callbacks and
two threads: a loop thread (free-running ticks, free-running stepping requests, paced
lockstep publications, republishing while paused) and a command thread (commands arrive
on a node of their own, taken from a wait set without an executor; in lockstep it also
times a step out). A receiver
(:mod:`.receiver`) validates a command once, the plant (:mod:`.plant`) owns the core
simulator and the clock, and the sender (:mod:`.sender`) turns samples into messages.

Bad commands (wrong lengths, unknown names, NaN/inf, over ``max_force`` or outside a rest
length's range, a command of the other kind, stamped for another step in lockstep) are
rejected with a warning naming the problem, throttled per reason (:mod:`..refusals`). In
lockstep, a command the last step ran under arriving again is a duplicate, dropped silently
(a controller answers a republished state again); publishing never stops and NaN is never integrated.
Free-running, after ``command_timeout`` seconds of play without a valid command the forces
drop to ``safe_force`` (rest lengths are held). When ``lambda1/L`` or ``lambda2/L`` falls
below ``singularity_warning`` a throttled warning says which set is near and how near.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from simulation_interfaces.msg import Result
from tensegrity_msgs.msg import ActuatorForces, CableCommand, SimulationEvent

from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import clip, excerpt
from tensegrity_ros.nodes.actuator_commands import CommandError
from tensegrity_ros.nodes.common import ParameterValueError, rclpy, spin_node
from tensegrity_ros.nodes.refusals import ReasonThrottle, reason_of
from tensegrity_ros.nodes.scene_param import declare_scene
from tensegrity_ros.nodes.sim import COMMANDS_NODE_SUFFIX, control, sender
from tensegrity_ros.nodes.sim.command_bytes import CableCommandBytes
from tensegrity_ros.nodes.sim.control import PLAYING, RUN_STATE_NAMES, Answer, StepRequest
from tensegrity_ros.nodes.sim.hold import CommandHold
from tensegrity_ros.nodes.sim.interfaces import SimulationInterfaces
from tensegrity_ros.nodes.sim.lockstep import LockstepGate
from tensegrity_ros.nodes.sim.outputs import Outputs
from tensegrity_ros.nodes.sim.pacer import LockstepPacer
from tensegrity_ros.nodes.sim.parameters import declare_sim_parameters
from tensegrity_ros.nodes.sim.plant import SimPlant
from tensegrity_ros.nodes.sim.receiver import Command, receive, receive_cable_bytes
from tensegrity_ros.nodes.sim.schedule import TickSchedule
from tensegrity_ros.rclpy_utils.delivery import wait_for_delivery
from tensegrity_ros.rclpy_utils.inbox import Inbox
from tensegrity_ros.rclpy_utils.matching import subscribed_by, wait_for_matches
from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services

#: Commands kept per command topic until the command thread takes them (see ``__init__``).
COMMAND_HISTORY = 100

class SimNode(SimulationInterfaces):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("tensegrity_sim", **kwargs)
        guard_parameter_services(self)
        scene_name, scene = declare_scene(self, class2_only=False)
        self.p = p = declare_sim_parameters(self, scene_name)
        try:
            self.plant = SimPlant(scene, p.step_ns)
        except TensegrityError as err:
            raise ParameterValueError(clip(f"tensegrity_sim: cannot start scene {excerpt(p.scene)}: {err}")) from None
        forces = self.plant.interface.command == "force"
        self.unit = self.plant.interface.unit
        self.outputs = Outputs(self.plant, publish_rate=p.publish_rate, state_rate=p.state_rate,
                               marker_rate=p.marker_rate, imu_rate=p.imu_rate, frame_prefix=p.frame_prefix)
        self.hold = CommandHold(self.plant.initial_command, p.command_timeout,
                                [p.safe_force] * len(self.plant.initial_command) if forces else None)
        self.schedule = TickSchedule(p.publish_rate, p.real_time_factor, p.step_ns)
        self.pacer = LockstepPacer(p.lockstep_real_time_factor, p.step_size)

        # History for a subscriber that falls briefly behind (a recorder on a loaded machine): a
        # reliable writer repairs what a reader missed only from what it still keeps (1 s of
        # a lockstep run at 1,000 steps/s; markers, large and slower, 100)
        qos = QoSProfile(depth=1000)       # /tf: tf2's broadcaster's (reliable, volatile, last 100)
        self.pubs = {topic: self.create_publisher(kind, topic, 100 if topic in ("markers", "/tf") else qos)
                     for topic, kind in self.outputs.topics.items()}
        self.pub_events = self.create_publisher(SimulationEvent, "events", qos)
        self.pub_clock = self.create_publisher(ClockMsg, "/clock", qos)
        self._header = sender.header(0, p.frame_id)     # every publication's, restamped
        # Commands arrive on a node of their own that no executor spins: the command thread
        # waits on its two subscriptions alone and takes them (an :class:`Inbox`). An rclpy
        # executor's wake-up walks every entity of its nodes (this node's services, action
        # server and parameter services: ~1 ms per wake-up here) and even on these two alone
        # costs a third of a lockstep step's CPU.
        # A command names the inputs it sets and leaves the others: each one counts, so both
        # kinds are kept and applied in order. A history of one would let a later command naming
        # other inputs replace an earlier one still queued (two publishers' partial commands
        # for one lockstep step, back to back): the earlier one's inputs would never be set. The
        # inbox takes all that is queued at each wake-up: a flood is applied at once.
        # Both command topics exist whatever the scene: a command of the other kind is
        # refused with a warning that names the right one.
        self._command_node = Node(self.get_name() + COMMANDS_NODE_SUFFIX, namespace=self.get_namespace(),
                                  context=self.context, start_parameter_services=False,
                                  parameter_overrides=[Parameter("start_type_description_service", value=False)])
        self._inbox = Inbox(self._command_node)
        self._inbox.subscribe(ActuatorForces, "actuator_forces", self.on_forces, COMMAND_HISTORY)
        self._cable_bytes = CableCommandBytes(self.plant.interface.inputs)
        self._inbox.subscribe(CableCommand, "cable_commands", self.on_cables, COMMAND_HISTORY, raw=True)
        self._create_interfaces()

        self.rejected, self._refusals = 0, ReasonThrottle(1.0)   # warnings: each reason at most once a second
        self.lockstep_timeouts = 0
        self.published = dict.fromkeys((*self.outputs.topics, "events", "/clock"), 0)
        self._lock = threading.Lock()        # plant, run state and publishing: loop thread vs. callbacks
        self.state = p.initial_state
        if self.state != PLAYING:
            self.hold.pause(time.monotonic())
        self.request: StepRequest | None = None
        self.gate = LockstepGate()           # lockstep: the command of the step the simulator waits at
        self._waiting_since = time.monotonic()
        self._due: float | None = None       # paced lockstep: wall time the stepped state is due
        self._pace_wait = 0.0                # paced lockstep: how long the loop thread sleeps
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._command_thread = threading.Thread(target=self._spin_commands, name="tensegrity_sim_commands",
                                                daemon=True)
        self._command_thread.start()
        self._thread = threading.Thread(target=self._loop, name="tensegrity_sim_loop", daemon=True)
        self._thread.start()
        pace = f", at most {p.lockstep_real_time_factor:g} x real time" if p.lockstep_real_time_factor > 0 else ""
        mode = (f"lockstep (timeout {p.lockstep_timeout:g} s{pace})" if p.lockstep else
                f"free-running at real-time factor {p.real_time_factor:g}"
                + (" (as fast as possible)" if p.real_time_factor == 0 else ""))
        inputs = self.plant.interface.inputs
        takes = f"{'actuator forces' if forces else 'rest lengths'} of {', '.join(inputs)}" if inputs else "no commands"
        self.get_logger().info(
            f"scene {excerpt(p.scene)}: publishing at {p.publish_rate:g} Hz, step {p.step_size:.9g} s, {mode}, "
            f"{RUN_STATE_NAMES[self.state]}; takes {takes}")
        for line in self.outputs.cap_warnings:
            self.get_logger().warning(line)

    def _spin_commands(self) -> None:
        """The command thread: take commands; in lockstep also check the step's timeout
        between waits (a timer would add an entity to every wake-up)."""
        poll = min(0.05, self.p.lockstep_timeout / 5)
        try:
            while rclpy.ok(context=self.context) and not self._stop.is_set():
                self._inbox.wait(poll)
                if self.p.lockstep and time.monotonic() - self._waiting_since >= poll:
                    self._on_lockstep_timer()
        except Exception:
            if rclpy.ok(context=self.context) and not self._stop.is_set():
                raise                        # a wait ended by the context's shutdown is the end

    # -- the loop thread: free-running ticks, free-running stepping requests, paused republishing
    def _loop(self) -> None:
        """One tick per publish period of wall (steady) time, or back to back in
        as-fast-as-possible mode. A thread with its own deadline keeps 1 kHz where an
        executor timer's per-callback overhead does not."""
        p = self.p
        if p.wait_for_subscribers > 0 or p.wait_for_node:
            publishers = (*self.pubs.values(), self.pub_clock)
            named = f" and {p.wait_for_node}'s" if p.wait_for_node else ""
            self.get_logger().info(f"waiting for {p.wait_for_subscribers} subscriber(s){named} on every output topic")
            wait_for_matches(publishers, max(1, p.wait_for_subscribers), should_stop=self._stop.is_set,
                             poll=self._stop.wait,
                             also=lambda: not p.wait_for_node or subscribed_by(self, publishers, p.wait_for_node))
        with self._lock:
            self._publish()                  # the state at t_0
            self._waiting_since = time.monotonic()
        idle_period = 1.0 / p.paused_publish_rate if p.paused_publish_rate > 0 else math.inf
        next_idle = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            delay = 0.0
            with self._lock:
                try:
                    work = self._loop_work(now)
                except Exception as err:  # a failing tick must never kill publishing silently
                    if not rclpy.ok(context=self.context):
                        return                  # shutting down: publishers are gone
                    self.get_logger().error(f"tick failed: {type(err).__name__}: {err}", throttle_duration_sec=1.0)
                    work = "idle"
                if work == "tick":
                    delay = self.schedule.wait(time.monotonic())
                else:
                    self.schedule.restart()
            if work == "tick":
                if delay > 0:
                    self._stop.wait(delay)
                continue
            if work == "step":
                continue
            if work == "pace":
                self._wake.wait(self._pace_wait)
                self._wake.clear()
                continue
            if now >= next_idle:
                if work == "idle" and idle_period < math.inf:
                    with self._lock:
                        self._publish()
                next_idle = now + idle_period
            self._wake.wait(min(0.05, max(0.0, next_idle - now)))
            self._wake.clear()

    def _loop_work(self, now: float) -> str:
        """One unit of the loop thread's work (lock held): ``"tick"`` (free-running play),
        ``"step"`` (one step of a free-running stepping request, or a paced lockstep state
        published), ``"pace"`` (a paced lockstep state is not due yet), ``"idle"`` (paused or
        stopped: republish at the slow rate) or ``"wait"`` (lockstep: the callbacks drive)."""
        if self.p.lockstep:
            if self._due is not None:
                if now < self._due:
                    self._pace_wait = self._due - now
                    return "pace"
                self._publish_due(now)
                return "step"
            return "idle" if self.state != PLAYING and self.request is None else "wait"
        if self.request is not None:
            self._request_step(self._effective_command(now))
            return "step"
        if self.state != PLAYING:
            return "idle"
        self._tick(now)
        return "tick"

    def _tick(self, now: float) -> None:
        """Free-running: the whole steps due by this tick of the schedule, then publish."""
        target = self.schedule.steps_due(self.plant.k)
        if target <= self.plant.k:
            return
        command = self._effective_command(now)
        while self.plant.k < target:
            self._step(command)
        self._publish()

    # -- stepping -------------------------------------------------------------------------------
    def _step(self, command: Sequence[float]) -> None:
        """One step of the plant under ``command``; publish what it located (lock held)."""
        outcome = self.plant.step(command)
        for event in outcome.events:
            self.pub_events.publish(sender.event_msg(event, self.plant.offset_ns, self.p.frame_id, self.plant.names))
            self.published["events"] += 1
        if outcome.fault is not None:
            self.get_logger().error(f"simulation stopped, state held: {outcome.fault}")

    def _request_step(self, command: Sequence[float]) -> None:
        """One step of the current stepping request, then publish, feedback, and finish it
        when done or cancelled (lock held)."""
        req = self.request
        assert req is not None                  # called only while a request runs
        if req.cancel_requested:
            self._end_request(Answer(Result.RESULT_OK, f"cancelled after {req.completed} of {req.steps} steps"))
            return
        self._step(command)
        self._publish()
        req.completed += 1
        if req.feedback is not None:
            req.feedback(req.completed, req.remaining)
        if req.remaining == 0:
            self._end_request(Answer(Result.RESULT_OK, f"{req.steps} steps done, t = {self._now_text()}"))

    def _end_request(self, answer: Answer) -> None:
        req, self.request = self.request, None
        if req is not None:
            req.finish(answer)

    def _start_request(self, req: StepRequest) -> Answer | None:
        """Start a stepping request, or the answer why not (lock held)."""
        refusal = control.check_step_request(req.steps, self.state, self.request, self.p.max_steps_per_request)
        if refusal is not None:
            return refusal
        self.request = req
        if self.p.lockstep:
            self._lockstep_begin()
        else:
            self._wake.set()
        return None

    # -- lockstep ---------------------------------------------------------------------------------
    def _may_step(self) -> bool:
        """Stepping is allowed (playing or a request runs) and no paced state is unpublished."""
        return (self.state == PLAYING or self.request is not None) and self._due is None

    def _lockstep_begin(self) -> None:
        """Stepping becomes allowed: step at once if the command for t_k is here, otherwise
        (re)publish the state at t_k for a controller that may have missed it and wait."""
        self._waiting_since = time.monotonic()
        self.pacer.restart()
        if self.gate.pending is not None:
            self._lockstep_advance()
        else:
            self._publish()

    def _lockstep_advance(self, command: Sequence[float] | None = None) -> None:
        """Integrate the step the simulator waits at, under the received command (or
        ``command``, the fallback after a timeout), when stepping is allowed (lock held)."""
        if self.request is not None and self.request.cancel_requested:
            req = self.request
            self._end_request(Answer(Result.RESULT_OK, f"cancelled after {req.completed} of {req.steps} steps"))
            return
        if not self._may_step():
            return
        if command is None:
            taken = self.gate.take()
            if taken is None:
                return
            command = taken.update.apply(self.hold.values)
            self.hold.set(command, time.monotonic())
        if self.request is not None:
            self._request_step(command)
        else:
            self._step(command)
            due = self.pacer.due(time.monotonic(), self.plant.k) if self.state == PLAYING else None
            if due is not None:
                self._due = self._waiting_since = due   # the step's timeout counts from its publication
                self._wake.set()
                return
            self._publish()
        self._waiting_since = time.monotonic()

    def _publish_due(self, now: float) -> None:
        """Publish the paced state that is due (lock held); its step now waits for its command."""
        self._due = None
        self._publish()
        self._waiting_since = now
        if self.gate.pending is not None:     # sent before it could have seen this state
            self._lockstep_advance()

    def _on_lockstep_timer(self) -> None:
        with self._lock:
            if self.request is not None and self.request.cancel_requested:
                self._lockstep_advance()
                return
            if not self._may_step() or time.monotonic() - self._waiting_since < self.p.lockstep_timeout:
                return
            self.lockstep_timeouts += 1
            runs = (f"runs under safe_force = {self.p.safe_force:g} N" if self.hold.safe is not None
                    else "holds the last rest lengths")
            self.get_logger().warning(
                f"lockstep: no command for step {self.plant.k} (t = {self._now_text()}) within "
                f"{self.p.lockstep_timeout:g} s: this step {runs} ({self.lockstep_timeouts} timed-out steps so far)",
                throttle_duration_sec=2.0)
            self._lockstep_advance(self.hold.fallback())

    # -- commands -----------------------------------------------------------------------------------
    def on_forces(self, msg: ActuatorForces) -> None:
        self._take("actuator", lambda: receive(msg, max_force=self.p.max_force, interface=self.plant.interface))

    def on_cables(self, raw: bytes) -> None:
        """A serialized CableCommand (taken raw: the usual lockstep command is read in place,
        :mod:`.command_bytes`)."""
        self._take("cable", lambda: receive_cable_bytes(raw, self._cable_bytes, interface=self.plant.interface))

    def _take(self, what: str, parse: Callable[[], Command]) -> None:
        """A command message: validate it (``parse()`` gives its :class:`Command`), then apply
        it as the mode says: the step the simulator waits at (lockstep) or the held command."""
        try:
            command = parse()
            with self._lock:
                if self.p.lockstep:
                    if self.gate.offer(command, self.plant.time_ns, self.plant.k):
                        self._lockstep_advance()
                    return
                if self.hold.set(command.update.apply(self.hold.values), time.monotonic()):
                    self.get_logger().info("commands resumed")
        except CommandError as err:
            self.rejected += 1
            if self._refusals.admit((what, reason_of(err)), time.monotonic()):
                self.get_logger().warning(clip(f"rejected {what} command: {err} ({self.rejected} rejected so far)"))

    def _effective_command(self, now: float) -> list[float]:
        command, timed_out = self.hold.effective(now)
        if timed_out:
            self.get_logger().warning(
                f"no valid command for {self.p.command_timeout:g} s: forces drop to {self.p.safe_force:g} N")
        return command

    # -- publishing -----------------------------------------------------------------------------------
    def _publish(self) -> None:
        """The clock and the model's topics of this publication (:mod:`.outputs`; lock held).
        A topic nobody subscribes to is skipped (there is no reader to deliver to; it saves
        about a fifth of a lockstep step)."""
        ns = self.plant.time_ns
        if self.p.publish_clock and self.pub_clock.get_subscription_count():
            self.pub_clock.publish(sender.clock_msg(ns))
            self.published["/clock"] += 1
        hdr = sender.restamp(self._header, ns)
        for topic, msg in self.outputs.messages(hdr, self._subscribed):
            self.pubs[topic].publish(msg)
            self.published[topic] += 1
        self._warn_near_singular()

    def _subscribed(self, topic: str) -> bool:
        return self.pubs[topic].get_subscription_count() > 0

    def _warn_near_singular(self) -> None:
        near = self.plant.singular_distance()
        if near is None or near[1] >= self.p.singularity_warning:
            return
        name, distance = near
        q = self.plant.sim.state.y
        self.get_logger().warning(
            f"state near the singular set {name}: {name}/L = {distance:.3g} (rho1 = {q[0]:.4g} m, "
            f"rho2 = {q[1]:.4g} m); accelerations lose accuracy like 1/{name}^2 and the simulation "
            "stops at 1e-3", throttle_duration_sec=2.0)

    def _now_text(self) -> str:
        return f"{self.plant.time_ns / sender.NS_PER_S:.9f} s"

    # -- resets and state changes ---------------------------------------------------------------------
    def _reset(self, *, keep_time: bool, why: str) -> None:
        """Back to the initial state (lock held): any stepping request ends, the held
        command is the scene's again, and the new state is published."""
        if self.request is not None:
            req = self.request
            self._end_request(Answer(Result.RESULT_OPERATION_FAILED,
                                     f"interrupted by {why} after {req.completed} of {req.steps} steps"))
        before = self._published_state()
        self.plant.reset(keep_time=keep_time)
        self.hold.reset(self.plant.initial_command)
        self.gate.reset(state_changed=self._published_state() != before)
        self._due = None
        self.pacer.restart()
        self.schedule.restart()
        self._publish()
        self._waiting_since = time.monotonic()

    def _published_state(self) -> tuple[int, tuple[float, ...]]:
        """What a controller answers: the time [ns] and the state vector (positions, rates)."""
        return self.plant.time_ns, tuple(map(float, self.plant.sim.state.y))

    def destroy_node(self) -> None:
        self._stop.set()
        self._wake.set()
        self._thread.join(timeout=5.0)
        self._inbox.wake()
        self._command_thread.join(timeout=5.0)
        self._command_node.destroy_node()
        with self._lock:
            # the executor is shut down by now, so a waiting request is not answered (its
            # client sees the service go away); a future completed now would need the executor
            req, self.request = self.request, None
        if req is not None:
            rclpy.logging.get_logger(f"{self.get_name()}_summary").warning(
                f"a stepping request was interrupted by the shutdown after {req.completed} of {req.steps} steps")
        if rclpy.ok(context=self.context):        # an external shutdown has ended the publishers' context
            late, why = wait_for_delivery([*self.pubs.values(), self.pub_events, self.pub_clock])
            if late:
                rclpy.logging.get_logger(f"{self.get_name()}_summary").warning(
                    f"not every subscriber acknowledged the last messages ({why}) on: {', '.join(late)}")
        counts = ", ".join(f"{k} {v}" for k, v in self.published.items())
        # the context may already be shut down (Ctrl-C): log without /rosout
        rclpy.logging.get_logger(f"{self.get_name()}_summary").info(
            f"published: {counts}; rejected commands: {self.rejected}; lockstep timeouts: {self.lockstep_timeouts}")
        self._action.destroy()
        super().destroy_node()  # type: ignore[no-untyped-call]  # rclpy's, through super(): not excluded by name


def main(argv: Sequence[str] | None = None) -> int:
    return spin_node(SimNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
