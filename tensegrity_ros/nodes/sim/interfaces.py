"""The ``simulation_interfaces`` standard and the ``reset`` service of ``tensegrity_sim``:
the services and the stepping action, as a part of the node class
(:class:`~tensegrity_ros.nodes.sim.node.SimNode` inherits :class:`SimulationInterfaces`).

``reset`` (std_srvs/Trigger: back to the initial state, the clock keeps running forward),
``get_simulator_features``, ``get_simulation_state``, ``set_simulation_state``,
``reset_simulation``, ``step_simulation`` and the action ``simulate_steps``. The answers'
rules (which transitions and requests are allowed, with which result code) are plain logic
in :mod:`.control`; these methods take the node's lock and apply them.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from rclpy.action import ActionServer, CancelResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.task import Future
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import Result
from simulation_interfaces.srv import (
    GetSimulationState,
    GetSimulatorFeatures,
    ResetSimulation,
    SetSimulationState,
    StepSimulation,
)
from std_srvs.srv import Trigger

from tensegrity_core.excerpt import excerpt
from tensegrity_ros.nodes.common import SERVICE_QOS
from tensegrity_ros.nodes.sim import control
from tensegrity_ros.nodes.sim.control import PAUSED, PLAYING, RUN_STATE_NAMES, STOPPED, Answer, StepRequest

if TYPE_CHECKING:
    from tensegrity_ros.nodes.sim.hold import CommandHold
    from tensegrity_ros.nodes.sim.parameters import SimParameters
    from tensegrity_ros.nodes.sim.plant import SimPlant
    from tensegrity_ros.nodes.sim.schedule import TickSchedule
    from tensegrity_ros.rclpy_utils.inbox import Inbox

#: Free-running StepSimulation requests up to this many steps run in the service callback.
SYNC_STEPS = 100
#: Feedback messages of one SimulateSteps goal kept for a client that reads them late.
FEEDBACK_DEPTH = 1000


class SimulationInterfaces(Node):
    """The services and the action of the simulator node (module docstring); the node
    provides the plant, the run state, the lock and the stepping (declared here for the
    type checker, defined by :class:`~tensegrity_ros.nodes.sim.node.SimNode`)."""

    p: SimParameters
    plant: SimPlant
    hold: CommandHold
    schedule: TickSchedule
    state: int                       # SimulationState value
    request: StepRequest | None      # the stepping request that runs, if any
    _lock: threading.Lock
    _wake: threading.Event
    _due: float | None
    _inbox: Inbox                    # the command subscriptions (the command thread takes them)

    if TYPE_CHECKING:
        def _reset(self, *, keep_time: bool, why: str) -> None: ...
        def _publish(self) -> None: ...
        def _lockstep_begin(self) -> None: ...
        def _request_step(self, command: Sequence[float]) -> None: ...
        def _effective_command(self, now: float) -> list[float]: ...
        def _start_request(self, req: StepRequest) -> Answer | None: ...
        def _end_request(self, answer: Answer) -> None: ...

    def _take_queued_commands(self) -> None:
        """Apply every command received before stepping starts (a stepping request, play; call
        without the lock). Commands and requests come on separate topics and threads: a command
        sent before the request may still be queued when the request is handled, and in lockstep
        the step would run without it (a second controller's partial command for that step would
        then be refused as stale)."""
        self._inbox.take_queued()

    def _create_interfaces(self) -> None:
        self.create_service(Trigger, "reset", self.on_reset)
        self.create_service(GetSimulatorFeatures, "get_simulator_features", self.on_get_features)
        self.create_service(GetSimulationState, "get_simulation_state", self.on_get_state)
        self.create_service(SetSimulationState, "set_simulation_state", self.on_set_state)
        self.create_service(ResetSimulation, "reset_simulation", self.on_reset_simulation)
        # The stepping requests await their end: in a group of their own (a mutually exclusive
        # group stays busy while a callback of it awaits, which would starve the commands).
        waiting = ReentrantCallbackGroup()
        self.create_service(StepSimulation, "step_simulation", self.on_step_simulation, qos_profile=SERVICE_QOS,
                            callback_group=waiting)
        # Feedback after every step: the writer keeps a goal's feedback until every reader has
        # it (a burst of free-running steps outruns the default history of 10)
        self._action = ActionServer(self, SimulateSteps, "simulate_steps", self.on_simulate_steps,
                                    cancel_callback=self._on_cancel, callback_group=waiting,
                                    feedback_pub_qos_profile=QoSProfile(depth=FEEDBACK_DEPTH))

    def on_reset(self, req: Trigger.Request, res: Trigger.Response) -> Trigger.Response:
        with self._lock:
            self._reset(keep_time=True, why="a reset")
        res.success, res.message = True, f"reset to the initial state of scene {excerpt(self.plant.scene.name)}"
        self.get_logger().info(res.message)
        return res

    def on_reset_simulation(self, req: ResetSimulation.Request, res: ResetSimulation.Response
                            ) -> ResetSimulation.Response:
        plan = control.reset_plan(int(req.scope))
        if plan.answer.ok:
            with self._lock:
                self._reset(keep_time=not plan.time, why="ResetSimulation")
        _fill(res.result, plan.answer)
        return res

    def on_get_features(self, req: GetSimulatorFeatures.Request, res: GetSimulatorFeatures.Response
                        ) -> GetSimulatorFeatures.Response:
        res.features.features = list(control.FEATURES)
        res.features.custom_info = (
            f"tensegrity_sim: step_size {self.p.step_size:.9g} s, lockstep {str(self.p.lockstep).lower()}, "
            f"inputs {self.plant.interface.command.replace('_', ' ')}s; located events on 'events'; the stepping "
            "contract is in docs/ros.md")
        return res

    def on_get_state(self, req: GetSimulationState.Request, res: GetSimulationState.Response
                     ) -> GetSimulationState.Response:
        with self._lock:
            res.state.state = self.state
        _fill(res.result, Answer(Result.RESULT_OK, RUN_STATE_NAMES[res.state.state]))
        return res

    def on_set_state(self, req: SetSimulationState.Request, res: SetSimulationState.Response
                     ) -> SetSimulationState.Response:
        target = int(req.state.state)
        if target == PLAYING:
            self._take_queued_commands()
        with self._lock:
            if self.request is not None and target == PLAYING:
                answer = Answer(Result.RESULT_INCORRECT_STATE, "a stepping request is running: cancel it or wait")
            elif self.request is not None and target in (PAUSED, STOPPED):
                req_ = self.request
                self._end_request(Answer(Result.RESULT_OPERATION_FAILED,
                                         f"interrupted by SetSimulationState after {req_.completed} of "
                                         f"{req_.steps} steps"))
                answer = self._set_state(target, force=True)
            else:
                answer = self._set_state(target)
        _fill(res.result, answer)
        if answer.ok:
            self.get_logger().info(f"simulation {answer.message}")
        return res

    def _set_state(self, target: int, *, force: bool = False) -> Answer:
        t = control.transition(self.state, target)
        if not t.answer.ok and not (force and t.state == target):
            return t.answer
        if t.reset:
            self._reset(keep_time=False, why="stopping")
        if self._due is not None:            # leaving paced play: the stepped state goes out now
            self._due = None
            self._publish()
        now = time.monotonic()
        self.state = target
        if target == PLAYING:
            self.hold.resume(now)
            self.schedule.restart()
            if self.p.lockstep:
                self._lockstep_begin()
            self._wake.set()
        else:
            self.hold.pause(now)
        return t.answer if t.answer.ok else Answer(Result.RESULT_OK, f"{RUN_STATE_NAMES[target]} (request ended)")

    # -- StepSimulation and SimulateSteps ---------------------------------------------------------------
    def _wait_future(self) -> Future:
        future = Future(executor=self.executor)
        future.add_done_callback(lambda _f: None)   # set_result then wakes the executor (guard condition)
        return future

    async def on_step_simulation(self, req: StepSimulation.Request, res: StepSimulation.Response
                                 ) -> StepSimulation.Response:
        if not self.p.lockstep and 0 < req.steps <= SYNC_STEPS:
            # a short free-running request runs right here: no hand-over to the loop thread
            # and back (which costs more than the steps)
            answers: list[Answer] = []
            with self._lock:
                refusal = control.check_step_request(int(req.steps), self.state, self.request,
                                                     self.p.max_steps_per_request)
                if refusal is None:
                    self.request = StepRequest(int(req.steps), done=answers.append)
                    while self.request is not None:
                        self._request_step(self._effective_command(time.monotonic()))
            _fill(res.result, refusal if refusal is not None else answers[0])
            return res
        future = self._wait_future()
        request = StepRequest(int(req.steps), done=future.set_result)
        self._take_queued_commands()
        with self._lock:
            refusal = self._start_request(request)
        _fill(res.result, refusal if refusal is not None else await future)
        return res

    def _on_cancel(self, goal_handle: Any) -> CancelResponse:
        with self._lock:
            req = self.request
            if req is not None and req.owner is goal_handle:
                req.cancel_requested = True
                self._wake.set()
        return CancelResponse.ACCEPT

    async def on_simulate_steps(self, goal_handle: Any) -> Any:
        future = self._wait_future()

        def feedback(completed: int, remaining: int) -> None:
            goal_handle.publish_feedback(SimulateSteps.Feedback(completed_steps=completed, remaining_steps=remaining))

        request = StepRequest(int(goal_handle.request.steps), done=future.set_result, feedback=feedback,
                              owner=goal_handle)
        self._take_queued_commands()
        with self._lock:
            refusal = self._start_request(request)
        answer = refusal if refusal is not None else await future
        result = SimulateSteps.Result()
        _fill(result.result, answer)
        if request.cancel_requested and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif answer.ok:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result


def _fill(result: Result, answer: Answer) -> None:
    result.result = answer.code
    result.error_message = answer.message
