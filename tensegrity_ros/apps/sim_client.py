"""A client of a stepping ``tensegrity_sim``: its ``simulation_interfaces`` services, and a
lockstep controller that answers every joint state with a command stamped like it.

The client's node spins on its own executor in a background thread, so that the
controller answers while the caller waits for a ``StepSimulation`` that needs those
answers. Calls wait on the response future with an event, never with
``spin_until_future_complete`` (7-12 ms per call here). The joint states, one per step,
are taken on a thread of their own from a node that no executor spins
(:class:`~tensegrity_ros.rclpy_utils.inbox.Inbox`): an executor's wake-up per message rebuilds
the wait set of every service client, action client and subscription of the node, about
twice the CPU of a take from the inbox's one wait set (the demo's ~6,400 joint states: 3.2-4.1 s
of its spinning thread's CPU, against 1.8-2.8 s there plus ~0.6 s on the joint states' thread).

The controller sees each joint state as a :class:`~tensegrity_core.sim.simulator.JointSample`
whose time is the stamp's integer nanoseconds divided once by 1e9 (the float the core's
sampled-data runner has at the same step), so a law evaluated here and in
:func:`tensegrity_core.sim.sampled.run_sampled` gives the same forces bit for bit. For a
general structure (``cables``: the actuated cables it commands, as ``CableCommand`` rest
lengths) the sample holds the joint state as published: cable lengths [m] as ``q``, their
rates as ``qdot``, tensions [N] as ``applied_forces`` (the core's sampled-data runner gives
a law the structure's coordinates instead: a law of the time alone, such as a gait, is the
same in both).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from tensegrity_core.class2 import end_effector_of
from tensegrity_core.class2.names import ACTUATORS
from tensegrity_core.sim.sampled import Controller
from tensegrity_core.sim.simulator import JointSample
from tensegrity_ros.rclpy_utils.spin_thread import SpinThread

if TYPE_CHECKING:
    from rclpy.context import Context

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class JointRecord:
    """One joint state as received: stamp [ns], position, velocity, effort (tuples of floats)."""

    stamp_ns: int
    position: tuple[float, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]


def cable_sample_of(record: JointRecord) -> JointSample:
    """The :class:`JointSample` a cable controller sees: lengths, rates, tensions as published."""
    return JointSample(record.stamp_ns / NS_PER_S, np.array(record.position, dtype=float),
                       np.array(record.velocity, dtype=float), np.array(record.effort, dtype=float), np.zeros(3),
                       False)


def sample_of(record: JointRecord, L: float = 1.0) -> JointSample:
    """The :class:`JointSample` a controller sees for a received joint state (``L`` [m]:
    strut length, for the end effector D)."""
    q = np.array(record.position[:3], dtype=float)
    ee = np.array([*end_effector_of(q, L), 0.0])
    return JointSample(record.stamp_ns / NS_PER_S, q, np.array(record.velocity[:3], dtype=float),
                       np.array(record.effort[:2], dtype=float), ee, False)


class SimClient:
    """Services of ``tensegrity_sim`` and a lockstep controller, on one node (of ``context``,
    default: rclpy's default context; call ``rclpy.init()`` first). ``law(sample) -> (f1, f2)`` [N] or None
    (then joint states are only recorded); with ``cables`` (names of actuated cables)
    ``law(sample)`` gives their rest lengths [m], sent as ``CableCommand``."""

    def __init__(self, rclpy: ModuleType, name: str = "tensegrity_sim_client", *, record_events: bool = True,
                 context: Context | None = None, namespace: str = "", cables: tuple[str, ...] | None = None) -> None:
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import JointState
        from simulation_interfaces.srv import (
            GetSimulationState,
            GetSimulatorFeatures,
            ResetSimulation,
            SetSimulationState,
            StepSimulation,
        )
        from std_srvs.srv import Trigger
        from tensegrity_msgs.msg import ActuatorForces, CableCommand, SimulationEvent

        from tensegrity_ros.rclpy_utils.inbox import InboxThread
        from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services

        self.rclpy = rclpy
        self.node = rclpy.create_node(name, namespace=namespace, context=context)
        guard_parameter_services(self.node)
        self.ActuatorForces, self.CableCommand = ActuatorForces, CableCommand
        self.cables = cables
        self.srv = {"set_simulation_state": SetSimulationState, "get_simulation_state": GetSimulationState,
                    "step_simulation": StepSimulation, "reset_simulation": ResetSimulation, "reset": Trigger,
                    "get_simulator_features": GetSimulatorFeatures}
        self.clients = {n: self.node.create_client(t, n) for n, t in self.srv.items()}
        self.pub = (self.node.create_publisher(CableCommand, "cable_commands", QoSProfile(depth=1000)) if cables
                    else self.node.create_publisher(ActuatorForces, "actuator_forces", QoSProfile(depth=1000)))
        self._joints = InboxThread(self.node, "joints")
        self._joints.inbox.subscribe(JointState, self.node.resolve_topic_name("joint_states"), self._on_joints,
                                     QoSProfile(depth=1000))
        self.events: list[Any] = []           # SimulationEvent messages
        if record_events:
            self.node.create_subscription(SimulationEvent, "events", self.events.append, QoSProfile(depth=1000))
        self.joints: list[JointRecord] = []
        self.law: Controller | None = None
        self._until_ns: int | None = None
        self._answered: set[int] = set()
        self._lock = threading.Lock()
        self._new = threading.Condition(self._lock)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        # until closed, or until the context shuts down (on Ctrl-C rclpy's signal handler
        # shuts it down; the caller's main thread reports the interruption)
        self._spinning = SpinThread(self.executor, f"{name}_spin", poll_s=0.05).start()
        self._joints.start()

    # -- the controller ------------------------------------------------------------------------
    def _on_joints(self, msg: Any) -> None:
        rec = JointRecord(msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec, tuple(msg.position),
                          tuple(msg.velocity), tuple(msg.effort))
        with self._lock:
            law = self.law
            self.joints.append(rec)
            self._new.notify_all()
            if law is not None:
                if rec.stamp_ns in self._answered:   # a state republished: it was answered already
                    return
                if self._until_ns is not None and rec.stamp_ns >= self._until_ns:
                    return                           # the run's end: no step follows it
                self._answered.add(rec.stamp_ns)
        if law is not None:
            if self.cables:
                cmd = self.CableCommand(name=list(self.cables),
                                        rest_length=[float(v) for v in law(cable_sample_of(rec))])
            else:
                f1, f2 = law(sample_of(rec))
                cmd = self.ActuatorForces(name=list(ACTUATORS), force=[float(f1), float(f2)])
            cmd.header.stamp = msg.header.stamp
            self.pub.publish(cmd)

    def set_law(self, law: Controller | None, *, until_ns: int | None = None) -> None:
        """Answer joint states with ``law`` from now on (None: stop answering). Each stamp is
        answered once per law: a state the simulator republishes (at the start of a stepping
        request, or while paused) gets no second command, which the simulator would reject
        as stamped for a past step. States stamped ``until_ns`` [ns] or later are not answered:
        a run of ``n`` steps from ``t_0`` answers ``t_0 .. t_(n-1)``; an answer to its final
        state would reach the simulator after the next reset and be rejected there as stamped
        for another step."""
        with self._lock:
            self.law = law
            self._until_ns = until_ns
            self._answered = set()

    def take_joints(self) -> list[JointRecord]:
        """The joint states received so far (and forget them)."""
        with self._lock:
            out, self.joints = self.joints, []
        return out

    def joints_since(self, stamp_ns: int) -> list[JointRecord]:
        """The joint states received since the last take stamped ``stamp_ns`` or later, in
        stamp order (a state published twice appears once)."""
        with self._lock:
            by_stamp = {j.stamp_ns: j for j in self.joints if j.stamp_ns >= stamp_ns}
        return [by_stamp[k] for k in sorted(by_stamp)]

    def wait_joint(self, stamp_ns: int | None = None, timeout: float = 30.0) -> JointRecord:
        """Wait for a joint state stamped ``stamp_ns`` (None: any, i.e. the first since the
        last take) and return it."""
        def found() -> JointRecord | None:
            return next((j for j in self.joints if stamp_ns is None or j.stamp_ns == stamp_ns), None)

        with self._lock:
            record = self._new.wait_for(found, timeout)
            if record is None:
                raise RuntimeError(f"no joint_states{'' if stamp_ns is None else f' stamped {stamp_ns} ns'} "
                                   f"within {timeout:g} s")
            return record

    # -- services ----------------------------------------------------------------------------------
    def wait_for_services(self, timeout: float = 60.0) -> None:
        """Wait for the simulator's services, and for every command writer of this client's
        participant made so far (this client's, and those of other nodes of its context) to be
        matched on both sides: this publisher has a subscriber, and the simulator has answered
        a ``get_simulation_state`` asked through a client made now, which proves that its
        reader has matched all those writers
        (:func:`~tensegrity_ros.rclpy_utils.matching.wait_until_answered`). A command
        written before the simulator's reader knew its writer would come late, repaired only
        after the step it was meant for had run, or never."""
        from tensegrity_ros.rclpy_utils.futures import wait_done
        from tensegrity_ros.rclpy_utils.matching import wait_for_matches, wait_for_service, wait_until_answered

        for client in self.clients.values():
            if not wait_for_service(client, timeout):
                raise RuntimeError(f"service {client.srv_name} not available within {timeout:g} s")
        if not wait_for_matches([self.pub], 1, timeout, settle_s=0.0):
            raise RuntimeError(f"nobody subscribes to {self.pub.topic_name} within {timeout:g} s")
        if not wait_until_answered(self.node, self.srv["get_simulation_state"], "get_simulation_state", wait_done,
                                   timeout):
            raise RuntimeError(f"the simulator did not answer get_simulation_state within {timeout:g} s")

    def call(self, name: str, request: Any = None, timeout: float = 600.0) -> Any:
        """Call the service ``name`` and wait up to ``timeout`` s for its answer."""
        client = self.clients[name]
        done = threading.Event()
        future = client.call_async(request if request is not None else self.srv[name].Request())
        future.add_done_callback(lambda _f: done.set())
        if not done.wait(timeout):
            client.remove_pending_request(future)
            raise RuntimeError(f"no answer from {client.srv_name} within {timeout:g} s")
        return future.result()

    def checked(self, name: str, request: Any = None, timeout: float = 600.0) -> Any:
        """``call`` a simulation_interfaces service and raise unless its result is OK."""
        from simulation_interfaces.msg import Result

        res = self.call(name, request, timeout)
        if res.result.result != Result.RESULT_OK:
            raise RuntimeError(f"{name} failed (result {res.result.result}): {res.result.error_message}")
        return res

    def set_state(self, state: int) -> Any:
        req = self.srv["set_simulation_state"].Request()
        req.state.state = state
        return self.call("set_simulation_state", req)

    def step(self, steps: int, timeout: float = 600.0) -> Any:
        return self.checked("step_simulation", self.srv["step_simulation"].Request(steps=steps), timeout)

    def step_received(self, steps: int, from_ns: int, step_ns: int, chunk: int = 50) -> None:
        """Step ``steps`` steps from the state stamped ``from_ns``, at most ``chunk`` at a
        time, each chunk only once this client has received the state the last one ended
        at. The simulator's publishers keep the last 100 samples for a reader that has not
        taken them yet; a lockstep loop runs ~1,000 steps/s, so a client on a loaded machine
        could fall further behind and lose joint states. Here it stays within ``chunk``."""
        done = 0
        while done < steps:
            n = min(chunk, steps - done)
            self.step(n)
            done += n
            self.wait_joint(from_ns + done * step_ns)

    def reset_all(self) -> Any:
        req = self.srv["reset_simulation"].Request(scope=self.srv["reset_simulation"].Request.SCOPE_ALL)
        return self.checked("reset_simulation", req)

    def restart(self) -> JointRecord:
        """Reset the simulation (:meth:`reset_all`) and forget the joint states received
        before it: those received from then on are the new run's, beginning with its state at
        t = 0, which this waits for and returns. The reset publishes that state before it
        answers, and whether it is received before or after the answer is thread timing, so
        a run that took the joint states after the answer had it or not by chance."""
        self.take_joints()
        self.reset_all()
        return self.wait_joint(0)

    def close(self) -> None:
        # the spinning thread ends first: shutting the executor down under a callback that
        # is running destroys the guard condition that callback triggers (InvalidHandle)
        self._spinning.stop()
        self._joints.close()
        self.executor.shutdown()
        self.node.destroy_node()
