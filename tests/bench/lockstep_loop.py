"""The lockstep control loop over DDS and its baseline, a bare rclpy ping-pong, driven from
this process: the measurement the stepping, general-structure and robot benchmarks share.

:class:`LockstepLoop` starts an echo process (``tests.bench.ros_echo_server``) and
``tensegrity node sim`` in lockstep with the given parameters, and a client node here that
answers every joint state once with the command ``answer()`` gives, stamped like it.

- :meth:`LockstepLoop.ping_pong`: ``n`` round trips JointState out to the echo, the
  loop's command back (the message ``answer()`` gives), the next JointState on its arrival
  (the same two hops and messages as the loop, no simulation); seconds per round trip.
- :meth:`LockstepLoop.lockstep`: one ``StepSimulation(n)``, each step state out, command in,
  one step; seconds per step.

Alternate the two in one run (both servers run throughout, so a change of the machine's
load hits both series alike). After each, :attr:`LockstepLoop.last` holds what a busy
machine distorts less than the mean: the median time between two consecutive answers at
the client (a preempted exchange moves the mean, hardly the median) and the CPU time the
answering process (the echo, or the simulator) spent per exchange, from ``/proc``.
:meth:`LockstepLoop.close` stops everything and checks that every step ran under its own
command (no rejected command, no lockstep timeout).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

from tests.bench.bench_ros import _start, _stop

#: Clock ticks per second of ``/proc/<pid>/stat``'s CPU times.
_TICKS = os.sysconf("SC_CLK_TCK")


def process_cpu_s(pid: int) -> float:
    """CPU seconds (user + system) process ``pid`` has used, from ``/proc/<pid>/stat``."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICKS


@dataclass(frozen=True)
class Exchanges:
    """One run of ``n`` exchanges: seconds per exchange (wall, over the run), the median
    seconds between consecutive answers at the client, and the answering process's CPU
    seconds per exchange."""

    mean_s: float
    median_gap_s: float
    server_cpu_s: float


def ros_client(env: dict, name: str = "bench_stepping_client"):
    """``(rclpy, context, node, executor)``: a node of its own context in this process, on
    ``env``'s ROS domain and discovery range."""
    import rclpy
    from rclpy.context import Context as RosContext
    from rclpy.executors import SingleThreadedExecutor

    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    rctx = RosContext()
    rclpy.init(args=[], context=rctx)
    node = rclpy.create_node(name, context=rctx)
    ex = SingleThreadedExecutor(context=rctx)
    ex.add_node(node)
    return rclpy, rctx, node, ex


class LockstepLoop:
    """A lockstep simulator, an echo server and the client closing the loop (module docstring).

    ``sim_params``: ``name:=value`` parameters of the simulator (lockstep, paused and no
    paused republishing are added); ``joints``: the ping's joint names; ``command_type`` and
    ``command_topic``: what the controller sends; ``answer()``: a new command message."""

    def __init__(self, env: dict, sim_params: list[str], *, n: int, joints: list[str], command_type: type,
                 command_topic: str, answer: Callable[[], object]):
        from rclpy.qos import QoSProfile
        from rclpy.serialization import serialize_message
        from sensor_msgs.msg import JointState
        from simulation_interfaces.srv import StepSimulation

        from tensegrity_ros.rclpy_utils.matching import wait_for_matches

        self.n = n
        self.n_wanted = n                 # pongs the current exchange waits for
        self.echo = subprocess.Popen([sys.executable, "-m", "tests.bench.ros_echo_server", "--answer",
                                      command_type.__name__, serialize_message(answer()).hex()], env=env,
                                     stdout=subprocess.PIPE, text=True)
        self.echo.stdout.readline()
        params = [*sim_params, "lockstep:=true", "initial_state:=paused", "paused_publish_rate:=0.0",
                  f"max_steps_per_request:={10 * n}", "lockstep_timeout:=60.0"]
        self.sim = _start(["node", "sim", "--ros-args", *[a for p in params for a in ("-p", p)]], env, "publishing at")
        self.rclpy, self.rctx, self.node, self.ex = ros_client(env)
        self.ping = self.node.create_publisher(JointState, "bench_ping", QoSProfile(depth=100))
        self.got = 0
        zeros = [0.0] * len(joints)
        self._ping_msg = lambda: JointState(name=list(joints), position=zeros, velocity=zeros, effort=zeros)
        self.node.create_subscription(command_type, "bench_pong", self._on_pong, QoSProfile(depth=100))
        self.pub = self.node.create_publisher(command_type, command_topic, QoSProfile(depth=100))
        self._answer = answer
        self._answered = -1
        self._arrivals: list[float] = []   # perf_counter of each answer of the current run
        #: The last run's :class:`Exchanges` (after :meth:`ping_pong` or :meth:`lockstep`).
        self.last: Exchanges | None = None
        self.node.create_subscription(JointState, "joint_states", self._on_state, QoSProfile(depth=100))
        self.step = self.node.create_client(StepSimulation, "step_simulation")
        if not self.step.wait_for_service(timeout_sec=30):
            raise RuntimeError("the lockstep simulator's step_simulation service did not appear within 30 s")
        if not wait_for_matches([self.ping, self.pub], 1, 30, poll=lambda s: self.ex.spin_once(timeout_sec=s)):
            raise RuntimeError("the echo's or the simulator's subscriptions did not match within 30 s")
        self._handshake()

    def _handshake(self, timeout_s: float = 30.0) -> None:
        """Ping until a pong comes back: the writers matched the readers on *both* sides of the
        echo (the echo's pong writer learns of this node's reader by its own discovery, which
        nothing here can watch; a pong written before that is lost)."""
        deadline = time.monotonic() + timeout_s
        self.got, self.n_wanted = 0, 1
        while self.got < 1:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the echo answered no ping within {timeout_s:g} s")
            self._send_ping()
            end = time.monotonic() + 0.1
            while self.got < 1 and time.monotonic() < end:
                self.ex.spin_once(timeout_sec=0.01)
        end = time.monotonic() + 0.3         # the answers to earlier pings of the handshake, if any
        while time.monotonic() < end:
            self.ex.spin_once(timeout_sec=0.01)

    def _send_ping(self) -> None:
        out = self._ping_msg()
        out.header.stamp.nanosec = self.got % 1_000_000_000
        self.ping.publish(out)

    def _on_pong(self, _msg) -> None:
        self._arrivals.append(time.perf_counter())
        self.got += 1
        if self.got < self.n_wanted:      # the last pong ends the exchange (it must not run on)
            self._send_ping()

    def _on_state(self, msg) -> None:
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        if stamp == self._answered:       # republished at the start of a request: answered already
            return
        self._arrivals.append(time.perf_counter())
        self._answered = stamp
        cmd = self._answer()
        cmd.header.stamp = msg.header.stamp
        self.pub.publish(cmd)

    def ping_pong(self, timeout_s: float = 120.0) -> float:
        """Seconds per bare round trip, over ``n``; a RuntimeError when the exchange stops
        (a message lost after the handshake) for ``timeout_s``."""
        self.got, self.n_wanted = 0, self.n
        self._arrivals, cpu0 = [], process_cpu_s(self.echo.pid)
        t0 = time.perf_counter()
        self._send_ping()
        last, progress = 0, time.monotonic()
        while self.got < self.n:
            self.ex.spin_once(timeout_sec=0.1)
            if self.got != last:
                last, progress = self.got, time.monotonic()
            elif time.monotonic() - progress > timeout_s:
                raise RuntimeError(f"the ping-pong stopped after {self.got} of {self.n} round trips")
        return self._ran(t0, cpu0, self.echo.pid)

    def lockstep(self) -> float:
        """Seconds per lockstep step, over one ``StepSimulation(n)``."""
        from simulation_interfaces.srv import StepSimulation

        from tensegrity_ros.rclpy_utils.futures import spin_until_done

        self._arrivals, cpu0 = [], process_cpu_s(self.sim.pid)
        t0 = time.perf_counter()
        future = self.step.call_async(StepSimulation.Request(steps=self.n))
        assert spin_until_done(self.ex, future, 600) and future.result().result.result == 1, future.result()
        return self._ran(t0, cpu0, self.sim.pid)

    def _ran(self, t0: float, cpu0: float, server: int) -> float:
        """Keep the run's :class:`Exchanges` in :attr:`last`; seconds per exchange."""
        mean = (time.perf_counter() - t0) / self.n
        gaps = sorted(b - a for a, b in zip(self._arrivals, self._arrivals[1:])) or [mean]
        self.last = Exchanges(mean, gaps[len(gaps) // 2], (process_cpu_s(server) - cpu0) / self.n)
        return mean

    def close(self) -> None:
        """Stop the client, the simulator and the echo; every step ran under its own command."""
        self.ex.shutdown()                  # its guard conditions go before the context
        self.node.destroy_node()
        self.rclpy.try_shutdown(context=self.rctx)
        log = _stop(self.sim)
        self.echo.send_signal(signal.SIGINT)
        self.echo.wait(30)
        assert "rejected commands: 0; lockstep timeouts: 0" in log, log[-2000:]
