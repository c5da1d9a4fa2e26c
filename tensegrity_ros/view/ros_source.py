"""Frames from a running suite over ROS 2, and the page's requests as the suite's own interfaces.

One node, ``tensegrity_view``, in the suite's namespace (any: ``--namespace``), on an
rclpy context and executor of its own spun by a thread. What it draws follows the
simulator's ``scene`` parameter (asked of ``tensegrity_sim``): the class-2 mechanism from
``mechanism_state`` (``tensegrity_msgs/MechanismState``; drawn as soon as one arrives, so a
bag played into the graph without a simulator is drawn too), a general structure or robot
from ``cable_states``, ``body_states`` or ``markers`` and ``contacts``
(:mod:`.ros_structure`). It asks ``get_simulation_state`` twice a second for the run state
(``get_simulator_features`` once, whose ``custom_info`` says whether the simulator runs in
lockstep); once that service has left the graph (the suite stopped), the last frame is shown
again as ``"no simulator"`` and the page says so, rather than a frozen time still "playing"; pauses, plays and steps through ``set_simulation_state`` and ``step_simulation``
(``simulation_interfaces``); while the page drives the inputs, publishes them at
``DRIVE_HZ``, inside the simulator's command timeout: ``actuator_forces``
(``tensegrity_msgs/ActuatorForces``, f1 and f2 [N], tension positive) or ``cable_commands``
(``tensegrity_msgs/CableCommand``, rest lengths [m]); and sends the class-2 controller's
``move_end_effector`` goals. Every request is asynchronous: its answer comes back to the
page as one line. Stopping the view destroys this node only.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable
from typing import Any, Final

from tensegrity_core.errors import TensegrityError
from tensegrity_ros.rclpy_utils.futures import on_executor
from tensegrity_ros.rclpy_utils.spin_thread import SpinThread
from tensegrity_ros.view.frame import Frame
from tensegrity_ros.view.frames import class2_topology, frame_of_mechanism_state
from tensegrity_ros.view.inputs import InputSpec
from tensegrity_ros.view.ros_structure import StructureLink
from tensegrity_ros.view.server import ViewError
from tensegrity_ros.view.source import Report, Sink
from tensegrity_ros.view.structure_frames import StructureMessages

#: Actuator commands per second while the page drives the forces (the simulator drops to its
#: safe force after ``command_timeout``, 0.5 s by default, without one).
DRIVE_HZ: Final = 20.0
#: Seconds the page waits for the controller to accept or refuse a move before saying it
#: got no answer (the goal itself then still runs if it arrived).
MOVE_ANSWER_S: Final = 10.0
#: The simulator's node name, whose ``scene`` parameter says what it simulates.
SIM_NODE: Final = "tensegrity_sim"
#: ``simulation_interfaces/SimulationState`` values -> the view's run states.
RUN_STATES: Final = {0: "stopped", 1: "playing", 2: "paused", 3: "quitting", 4: "no world", 5: "loading world"}
#: The run state once the simulator's ``get_simulation_state`` has left the graph.
NO_SIMULATOR: Final = "no simulator"
#: ``simulation_interfaces/Result`` codes by value, for the page's lines.
RESULT_NAMES: Final = {0: "FEATURE_UNSUPPORTED", 1: "OK", 2: "NOT_FOUND", 3: "INCORRECT_STATE", 4: "OPERATION_FAILED",
                       101: "ALREADY_IN_TARGET_STATE", 102: "STATE_TRANSITION_ERROR", 103: "INCORRECT_TRANSITION"}


def run_state_name(state: int, lockstep: bool) -> str:
    """The run state a frame reports: a playing lockstep simulator is ``"lockstep"``."""
    name = RUN_STATES.get(int(state), "unknown")
    return "lockstep" if lockstep and name == "playing" else name


def _ignore(_text: str) -> None:
    """A report nobody reads (before :meth:`RosSource.start`)."""


class RosSource:
    """The simulator of a running suite in ``namespace`` (see the module docstring);
    ``force_limit`` [N] bounds the class-2 force sliders; ``ros_args`` go to rclpy (remapping);
    ``move_answer_s`` [s]: how long a move waits for the controller's answer.
    ``topology``, ``features`` and ``inputs`` are the class-2 mechanism's until
    :meth:`first_frame` has found a general structure or robot."""

    duration = 0.0
    tension_scale = 0.0

    def __init__(self, namespace: str = "", *, force_limit: float = 5.0, ros_args: list[str] | None = None,
                 move_answer_s: float = MOVE_ANSWER_S):
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self.topology = class2_topology()
        self.move_answer_s = move_answer_s
        self.features = frozenset({"run", "step", "inputs", "move"})
        self.inputs = tuple(InputSpec(name, "N", -force_limit, force_limit, 0.0) for name in ("f1", "f2"))
        self.context = Context()
        rclpy.init(args=["tensegrity", *(ros_args or [])], context=self.context,
                   signal_handler_options=SignalHandlerOptions.NO)
        try:
            self._make_node(namespace)
        except BaseException:
            rclpy.try_shutdown(context=self.context)
            raise
        self.label = f"suite {self.node.get_namespace()}: {self.node.resolve_topic_name('mechanism_state')}"
        self._sink: Sink | None = None
        self._report: Report = _ignore
        self._lock = threading.Lock()
        self._moves = 0                   # Move D presses: only the latest one's answers are shown
        self._first = threading.Event()
        self._latest: Frame | None = None
        self._run_state = "unknown"
        self._lockstep: bool | None = None
        self._simulator_seen = False      # its get_simulation_state was on the graph once
        self._heard = False               # the simulator has answered get_simulation_state (since it came)
        self._unsent: list[Callable[[], None]] = []   # requests waiting for that
        self._drive: dict[str, float] | None = None
        self._link: StructureLink | None = None
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stopped = False
        self._spinner = SpinThread(self.executor, "view_ros").start()

    def _make_node(self, namespace: str) -> None:
        from rclpy.action import ActionClient
        from rclpy.node import Node
        from rclpy.parameter_client import AsyncParameterClient
        from rclpy.qos import QoSProfile
        from simulation_interfaces.srv import (
            GetSimulationState,
            GetSimulatorFeatures,
            SetSimulationState,
            StepSimulation,
        )
        from tensegrity_msgs.action import MoveEndEffector
        from tensegrity_msgs.msg import ActuatorForces, MechanismState

        from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services

        self.node = Node("tensegrity_view", namespace=namespace or None, context=self.context)
        guard_parameter_services(self.node)
        node = self.node
        node.create_subscription(MechanismState, "mechanism_state", self._on_state, QoSProfile(depth=10))
        self.get_features = node.create_client(GetSimulatorFeatures, "get_simulator_features")
        self.set_state = node.create_client(SetSimulationState, "set_simulation_state")
        self.step_client = node.create_client(StepSimulation, "step_simulation")
        self.mover = ActionClient(node, MoveEndEffector, "move_end_effector")
        self.parameters = AsyncParameterClient(node, SIM_NODE)
        self.forces = node.create_publisher(ActuatorForces, "actuator_forces", QoSProfile(depth=10))
        # made last: the simulator's answer to it proves it has matched every endpoint above
        # (announced in creation order; docs/design/ros.md, "First answers"), so a play, pause
        # or step waits for one before it is sent, and its answer is not lost
        self.get_state = node.create_client(GetSimulationState, "get_simulation_state")
        self.ActuatorForces = ActuatorForces
        self.srv = {"get": GetSimulationState, "features": GetSimulatorFeatures, "set": SetSimulationState,
                    "step": StepSimulation}
        self.MoveEndEffector = MoveEndEffector
        node.create_timer(0.5, self._poll_state)
        node.create_timer(1.0 / DRIVE_HZ, self._publish_drive)

    # -- frames ------------------------------------------------------------------------------
    def _on_state(self, msg: Any) -> None:
        if self._link is None:
            self._on_frame(frame_of_mechanism_state(msg, self._run_state))

    def _on_frame(self, frame: Frame) -> None:
        with self._lock:
            self._latest = frame
            sink = self._sink
        self._first.set()
        if sink is not None:
            sink(frame)

    def first_frame(self, timeout: float) -> Frame:
        """The first state: a ``mechanism_state``, or, once the simulator has said that its scene
        is a general structure or robot, the first frame of its topics."""
        deadline = time.monotonic() + timeout
        asked: Any = None                 # the simulator's answer to "which scene?"
        answered = False
        while not self._first.wait(0.05):
            if time.monotonic() > deadline:
                topic = self._link.structure.nodes_topic if self._link else "mechanism_state"
                topic = self.node.resolve_topic_name(topic)     # before stop() destroys the node
                self.stop()
                raise ViewError(f"no state on {topic} within {timeout:g} s "
                                "(is the suite up? `tensegrity up`; in a namespace: --namespace)")
            if self._link is not None and self._link.error is not None:
                self.stop()
                raise ViewError(str(self._link.error))
            if answered:
                continue
            if asked is None and self.parameters.services_are_ready():
                asked = self.parameters.get_parameters(["scene"])
            elif asked is not None and asked.done():
                answered = True
                if asked.result() is not None and asked.result().values:
                    self._follow(str(asked.result().values[0].string_value))
        if self._link is not None:
            self.inputs = self._link.inputs()
            self.features = frozenset({"run", "step"} | ({"inputs"} if self.inputs else set()))
        with self._lock:
            assert self._latest is not None
            return self._latest

    def _follow(self, scene: str) -> None:
        """Draw the general structure or robot of ``scene`` (the class-2 mechanism: nothing to do)."""
        from tensegrity_core.sim import load_scene

        try:
            if load_scene(scene).model.kind == "class2":
                return
            structure = StructureMessages(scene)
        except TensegrityError as err:
            self.stop()
            raise ViewError(f"the simulator's scene {scene!r} cannot be drawn here: {err}") from None
        self.topology = structure.topology
        self._link = StructureLink(self.node, structure, self._on_frame, lambda: self._run_state)
        self.label = f"suite {self.node.get_namespace()}: {self.node.resolve_topic_name(structure.nodes_topic)}"

    def start(self, sink: Sink, report: Report) -> None:
        with self._lock:
            self._sink = sink
            self._report = report

    def stop(self) -> None:
        import rclpy

        if self._stopped:
            return
        self._stopped = True
        self._spinner.stop()              # joined before the executor and the node go
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    # -- the run state ------------------------------------------------------------------------
    def _poll_state(self) -> None:
        if self._lockstep is None and self.get_features.service_is_ready():
            # asked at each poll until one answers (it changes nothing; a slow answer still counts):
            # the answer to a request sent before the simulator matched this client's response
            # reader is lost
            self.get_features.call_async(self.srv["features"].Request()).add_done_callback(self._on_features)
        if self.get_state.service_is_ready():
            self._simulator_seen = True
            self.get_state.call_async(self.srv["get"].Request()).add_done_callback(self._on_run_state)
        elif self._simulator_seen and self._run_state != NO_SIMULATOR:
            self._simulator_gone()

    def _simulator_gone(self) -> None:
        """The simulator left the graph: no state will come, so the page must not go on saying
        "playing" over a frozen time; a simulator that comes back is followed again."""
        self._run_state = NO_SIMULATOR
        self._lockstep = None             # a simulator started again may run otherwise
        with self._lock:
            self._heard = False
        with self._lock:
            latest = self._latest
        if latest is None:
            return
        self._on_frame(dataclasses.replace(latest, run_state=NO_SIMULATOR))
        self._report(f"the simulator has gone ({self.node.resolve_service_name(self.get_state.srv_name)} left the graph): "
                     f"the last state shown is t = {latest.t:.3f} s")

    def _on_features(self, future: Any) -> None:
        res = future.result()
        if res is not None:
            self._lockstep = "lockstep true" in res.features.custom_info

    def _on_run_state(self, future: Any) -> None:
        res = future.result()
        if res is not None:
            with self._lock:
                self._heard, unsent, self._unsent = True, self._unsent, []
            for send in unsent:
                send()
            self._run_state = run_state_name(res.state.state, bool(self._lockstep))

    # -- requests ----------------------------------------------------------------------------
    def _call(self, client: Any, request: Any, what: str) -> None:
        if not client.service_is_ready():
            self._report(f"{what}: {client.srv_name} is not available (is the simulator running?)")
            return

        def done(future: Any) -> None:
            res = future.result()
            if res is None:
                self._report(f"{what}: no answer")
                return
            code = int(res.result.result)
            text = f"{what}: {RESULT_NAMES.get(code, code)}"
            self._report(f"{text} ({res.result.error_message})" if res.result.error_message else text)

        def send() -> None:
            client.call_async(request).add_done_callback(done)

        with self._lock:
            if not self._heard:
                self._unsent.append(send)
                return
        send()

    def _set_state(self, state: int, what: str) -> None:
        request = self.srv["set"].Request()
        request.state.state = state
        self._call(self.set_state, request, what)

    def play(self) -> None:
        self._set_state(1, "play")

    def pause(self) -> None:
        self._set_state(2, "pause")

    def step(self, steps: int) -> None:
        self._call(self.step_client, self.srv["step"].Request(steps=int(steps)), f"step {steps}")

    def drive(self, values: dict[str, float] | None) -> None:
        if values is not None and self._lockstep:
            self._report("the simulator runs in lockstep: it takes one command per step from its controller, "
                         "not from sliders")
            return
        with self._lock:
            self._drive = None if values is None else dict(values)
        what = "f1, f2" if self._link is None else "the rest lengths"
        self._report(f"the sliders drive {what}" if values is not None else f"the sliders let go of {what}")

    def _publish_drive(self) -> None:
        with self._lock:
            values = self._drive
        if values is None:
            return
        if self._link is not None:
            self._link.publish(values)
            return
        msg = self.ActuatorForces(name=list(values), force=[float(v) for v in values.values()])
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.forces.publish(msg)

    def move(self, x: float, y: float, duration: float) -> None:
        if not self.mover.server_is_ready():
            self._report("move: no controller answers move_end_effector (is it running? `tensegrity up`)")
            return
        goal = self.MoveEndEffector.Goal(x=float(x), y=float(y), duration=float(duration))
        with self._lock:
            self._moves += 1
            move = self._moves
        self._report(f"move: D to ({x:g}, {y:g}) m in {duration:g} s sent")
        answered = threading.Event()

        def latest() -> bool:
            # the page's line is the latest Move D's: an earlier goal's late answer (it was
            # pressed again, and this goal preempted it) is not shown over it
            with self._lock:
                return move == self._moves

        def unanswered() -> None:
            # a goal request (or its answer) lost while discovery still matches the action's
            # endpoints, or a controller gone, would otherwise leave the page at "sent" for good
            if not answered.is_set() and latest():
                self._report(f"move: no answer from the controller within {self.move_answer_s:g} s "
                             "(press Move D again)")

        def accepted(future: Any) -> None:
            answered.set()
            handle = future.result()
            if not latest():
                return
            if handle is None or not handle.accepted:
                self._report("move: the controller refused the goal")
                return
            handle.get_result_async().add_done_callback(finished)

        def finished(future: Any) -> None:
            if not latest():
                return
            res = future.result().result
            if res.error_code == 0:
                p = res.end_effector
                self._report(f"move: D at ({p.x:.4f}, {p.y:.4f}) m, {res.settled_error * 1e3:.2f} mm from the target")
            else:
                self._report(f"move: failed ({res.error_code}): {res.error_string}")

        timer = threading.Timer(self.move_answer_s, unanswered)
        timer.daemon = True
        timer.start()
        # sent by the spinning thread: from this (the page's) thread, rclpy could take the answer
        # before it knows the request and drop it (rclpy_utils.futures.on_executor)
        on_executor(self.executor, lambda: self.mover.send_goal_async(goal)).add_done_callback(
            lambda task: task.result().add_done_callback(accepted))

    def seek(self, t: float) -> None:
        self._report("no timeline: this is the live suite")

    def set_rate(self, rate: float) -> None:
        self._report("no timeline: this is the live suite")
