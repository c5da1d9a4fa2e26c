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

import signal
import statistics
import subprocess
import sys

import numpy as np

from tests.bench.bench_ros import _env, _round_trips, _start, _stop
from tests.bench.harness import Context, Row, benchmark
from tests.bench.lockstep_loop import LockstepLoop


def _loops(env: dict, n: int, rounds: int) -> tuple[list, list]:
    """Seconds per round trip of the bare ping-pong and per lockstep step, measured in
    alternating runs of ``n`` (``rounds`` each, after one warm-up of each)."""
    from tensegrity_msgs.msg import ActuatorForces

    loop = LockstepLoop(env, ["step_size:=0.001", "publish_rate:=1000.0", "state_rate:=0.0", "marker_rate:=0.0"],
                        n=n, joints=["rho1", "rho2", "beta"], command_type=ActuatorForces,
                        command_topic="actuator_forces",
                        answer=lambda: ActuatorForces(name=["f1", "f2"], force=[-0.35, 0.35]))   # holding forces
    bare, steps = [], []
    for r in range(rounds + 1):
        b, s_ = loop.ping_pong(), loop.lockstep()
        if r:                              # the first round warms up
            bare.append(b)
            steps.append(s_)
    loop.close()
    return bare, steps


@benchmark
def lockstep_loop(ctx: Context) -> list[Row]:
    env = _env()
    n, rounds = (100, 1) if ctx.quick else (1000, 7)
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
    n = 100 if ctx.quick else 1000
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
