"""Benchmarks of stepping ``tensegrity_sim`` over DDS (``python -m tests.bench --only stepping``).

1. The lockstep control loop: ``tensegrity node sim`` in lockstep (step 1 ms, the paper's
   mechanism at rest; joint_states, end_effector and /clock each step, no mechanism_state
   or markers), one ``StepSimulation(N)`` while a controller in this process answers every
   joint state with a command stamped like it (state out, command in, one step). Steps per
   second against a bare rclpy ping-pong measured in the same run: JointState out to an
   echo process, ActuatorForces back, the next JointState on its arrival (the same two
   hops and types, no simulation). Claims: >= 500 steps/s and >= 0.7 of the ping-pong.
2. ``StepSimulation(1)`` round trip (free-running simulator, paused): median and p99 of
   sequential calls against a bare rclpy service (std_srvs/Trigger answered at once, the
   same client code) in the same run.

Quick mode: 500 loop steps, 200 calls; full mode: 5,000 steps, 1,000 calls.
"""

from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import time

import numpy as np

from tests.bench.bench_ros import _env, _round_trips, _start, _stop
from tests.bench.harness import Context, Row, benchmark


def _client(env: dict):
    import rclpy
    from rclpy.context import Context as RosContext
    from rclpy.executors import SingleThreadedExecutor

    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    rctx = RosContext()
    rclpy.init(args=[], context=rctx)
    node = rclpy.create_node("bench_stepping_client", context=rctx)
    ex = SingleThreadedExecutor(context=rctx)
    ex.add_node(node)
    return rclpy, rctx, node, ex


def _loops(env: dict, n: int, rounds: int) -> tuple[list, list]:
    """Seconds per round trip of the bare ping-pong and per lockstep step, measured in
    alternating runs of ``n`` (``rounds`` each, after one warm-up of each): both servers run
    throughout, so a change of the machine's load hits both series alike."""
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from simulation_interfaces.srv import StepSimulation
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    echo = subprocess.Popen([sys.executable, "-m", "tests.bench.ros_echo_server"], env=env,
                            stdout=subprocess.PIPE, text=True)
    echo.stdout.readline()
    sim = _start(["node", "sim", "--ros-args", "-p", "lockstep:=true", "-p", "initial_state:=paused",
                  "-p", "step_size:=0.001", "-p", "publish_rate:=1000.0", "-p", "state_rate:=0.0",
                  "-p", "marker_rate:=0.0", "-p", "paused_publish_rate:=0.0",
                  "-p", f"max_steps_per_request:={10 * n}", "-p", "lockstep_timeout:=60.0"], env, "publishing at")
    rclpy, rctx, node, ex = _client(env)
    # the ping-pong: JointState out, the echo's ActuatorForces back, the next JointState
    ping = node.create_publisher(JointState, "bench_ping", QoSProfile(depth=100))
    got = [0]

    def send_ping() -> None:
        out = JointState(name=["rho1", "rho2", "beta"], position=[0.7, 0.7, 0.8], velocity=[0.0, 0.0, 0.0],
                         effort=[0.0, 0.0, 0.0])
        out.header.stamp.nanosec = got[0] % 1_000_000_000
        ping.publish(out)

    def on_pong(msg) -> None:
        got[0] += 1
        if got[0] < n:                    # the last pong ends the exchange (it must not run on)
            send_ping()

    node.create_subscription(ActuatorForces, "bench_pong", on_pong, QoSProfile(depth=100))
    # the lockstep controller: each joint state answered once with the holding forces
    pub = node.create_publisher(ActuatorForces, "actuator_forces", QoSProfile(depth=100))
    hold = [-0.35, 0.35]
    answered = [-1]

    def on_state(msg) -> None:
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        if stamp == answered[0]:          # republished at the start of a request: answered already
            return
        answered[0] = stamp
        cmd = ActuatorForces(name=["f1", "f2"], force=hold)
        cmd.header.stamp = msg.header.stamp
        pub.publish(cmd)

    node.create_subscription(JointState, "joint_states", on_state, QoSProfile(depth=100))
    step = node.create_client(StepSimulation, "step_simulation")
    step.wait_for_service(timeout_sec=30)
    wait_for_matches([ping, pub], 1, 30, poll=lambda s: ex.spin_once(timeout_sec=s))

    def ping_pong() -> float:
        got[0] = 0
        t0 = time.perf_counter()
        send_ping()
        while got[0] < n:
            ex.spin_once(timeout_sec=1.0)
        return (time.perf_counter() - t0) / n

    def lockstep() -> float:
        t0 = time.perf_counter()
        future = step.call_async(StepSimulation.Request(steps=n))
        assert spin_until_done(ex, future, 600) and future.result().result.result == 1, future.result()
        return (time.perf_counter() - t0) / n

    bare, loop = [], []
    for r in range(rounds + 1):
        b, s_ = ping_pong(), lockstep()
        if r:                              # the first round warms up
            bare.append(b)
            loop.append(s_)
    node.destroy_node()
    rclpy.try_shutdown(context=rctx)
    log = _stop(sim)
    echo.send_signal(signal.SIGINT)
    echo.wait(30)
    assert "rejected commands: 0; lockstep timeouts: 0" in log, log[-2000:]    # one command per step
    return bare, loop


@benchmark
def lockstep_loop(ctx: Context) -> list[Row]:
    env = _env()
    n, rounds = (250, 2) if ctx.quick else (1000, 7)
    bare, loop = _loops(env, n, rounds)
    b, s_ = statistics.median(bare), statistics.median(loop)
    ratios = sorted(x / y for x, y in zip(bare, loop))
    return [
        Row("stepping", "bare rclpy ping-pong round trip", b * 1e3, "ms",
            note=f"{1 / b:.0f} round trips/s; median of {rounds} runs of {n}"),
        Row("stepping", "lockstep step (state out, command in, one step)", s_ * 1e3, "ms",
            baseline="bare rclpy ping-pong round trip", target="ratio >= 0.7",
            note=f"{1 / s_:.0f} steps/s; runs alternating with the ping-pong; per-pair ratios "
                 f"{ratios[0]:.2f}..{ratios[-1]:.2f}"),
        Row("stepping", "lockstep steps per second", 1 / s_, "steps/s", target=">= 500"),
    ]


@benchmark
def step_simulation_round_trip(ctx: Context) -> list[Row]:
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import SetSimulationState, StepSimulation
    from std_srvs.srv import Trigger

    env = _env()
    n = 200 if ctx.quick else 1000
    echo = subprocess.Popen([sys.executable, "-m", "tests.bench.ros_echo_server"], env=env,
                            stdout=subprocess.PIPE, text=True)
    echo.stdout.readline()
    bare = _round_trips(Trigger, "bench_echo", [Trigger.Request() for _ in range(n)], env)
    echo.send_signal(signal.SIGINT)
    echo.wait(30)
    sim = _start(["node", "sim", "--ros-args", "-p", "initial_state:=paused", "-p", "step_size:=0.001",
                  "-p", "publish_rate:=1000.0", "-p", "paused_publish_rate:=0.0"], env, "publishing at")
    paused = SetSimulationState.Request()
    paused.state.state = SimulationState.STATE_PAUSED
    times = _round_trips(StepSimulation, "step_simulation", [StepSimulation.Request(steps=1) for _ in range(n)], env)
    _stop(sim)
    return [
        Row("stepping", "bare rclpy service round trip median", statistics.median(bare) * 1e3, "ms"),
        Row("stepping", "bare rclpy service round trip p99", float(np.percentile(bare, 99)) * 1e3, "ms"),
        Row("stepping", "StepSimulation(1) round trip median", statistics.median(times) * 1e3, "ms",
            baseline="bare rclpy service round trip median", note=f"{n} sequential calls, step 1 ms"),
        Row("stepping", "StepSimulation(1) round trip p99", float(np.percentile(times, 99)) * 1e3, "ms",
            baseline="bare rclpy service round trip p99"),
    ]
