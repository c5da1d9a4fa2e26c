"""Benchmarks of ``tensegrity_sim`` on a general structure (``python -m tests.bench --only general_ros``).

The actuated tensegrity table (``table_actuated``: one moving body, four members, three of
them commanded; DOP853), step 10 ms, rest lengths (0.88, 0.9, 0.92) m from the first
command on (the top tilts and sways). The simulation itself costs most of a step here, and
its cost depends on the motion, so each ROS figure is set against the core doing exactly the
same steps (the same floats: the node calls the core as the sampled-data runner does) in
this process, in the same run:

1. Free-running as fast as possible (``real_time_factor: 0``: one step per tick, each
   publishing joint_states, cable_states, body_states and /clock): the steps the node made
   in a wall-time window, against the core's ``set_command`` + ``advance`` + ``observe`` of
   the same steps afterwards (what the node does per publication). Claim: the node keeps
   >= 0.8 of the core's rate.
2. Lockstep: ``StepSimulation(N)`` while a client in this process answers every joint state
   with a ``CableCommand`` stamped like it, alternating with the core making the same N
   steps (a simulator in this process that mirrors the node's) and with a bare rclpy
   ping-pong (JointState out, a command back). Claim: what the loop adds to the core's step
   is <= 2 ping-pong round trips.

Quick mode (CI's smoke run: every row reported, no speed proven): 0.5 s free-running, 1 x 20
lockstep steps (after a warm-up run); full mode: 15 s, 5 x 200 steps.
"""

from __future__ import annotations

import os
import statistics
import time

from tests.bench.bench_ros import _env, _start, _stop
from tests.bench.harness import Context, Row, benchmark
from tests.bench.lockstep_loop import LockstepLoop, ros_client

SCENE = "table_actuated"
STEP_NS = 10_000_000


COMMAND = [0.88, 0.9, 0.92]


class CoreMirror:
    """The core stepping ``SCENE`` as the node does: held 0.9 m until step ``first``, then
    :data:`COMMAND`; observing after every step."""

    def __init__(self, first: int = 0):
        from tensegrity_core.sim import Simulator

        self.sim = Simulator(SCENE)
        self.first = first
        self.k = 0

    def run(self, n: int) -> float:
        """Make ``n`` steps; seconds per step."""
        from tensegrity_core.sim.sampled import step_time

        t0 = time.perf_counter()
        for _ in range(n):
            self.sim.set_command(COMMAND if self.k >= self.first else [0.9, 0.9, 0.9])
            self.k += 1
            self.sim.advance(step_time(self.k, STEP_NS))
            self.sim.observe()
        return (time.perf_counter() - t0) / n


@benchmark
def free_running(ctx: Context) -> list[Row]:
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import SetSimulationState
    from tensegrity_msgs.msg import CableCommand, CableStates, RigidBodyStates

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    env = _env()
    duration = 0.5 if ctx.quick else 15.0
    sim = _start(["node", "sim", "--ros-args", "-p", f"scene:={SCENE}", "-p", "real_time_factor:=0.0",
                  "-p", "publish_rate:=100.0", "-p", "step_size:=0.01", "-p", "state_rate:=100.0",
                  "-p", "marker_rate:=0.0", "-p", "command_timeout:=0.0", "-p", "initial_state:=paused",
                  "-p", "paused_publish_rate:=0.0"], env, "publishing at")
    rclpy, rctx, node, ex = ros_client(env)
    got = {"joint_states": 0, "body_states": 0}
    first: list[int] = []          # the step from which the command holds (its first state shows it)
    seen: list[tuple[float, int]] = []      # (wall time, step) of each cable_states

    def on_cables(msg) -> None:
        k = (msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec) // STEP_NS
        seen.append((time.monotonic(), k))
        if not first and msg.rest_length[0] == COMMAND[0]:
            first.append(k - 1)

    for topic, kind in (("joint_states", JointState), ("body_states", RigidBodyStates)):
        node.create_subscription(kind, topic, lambda _m, t=topic: got.__setitem__(t, got[t] + 1),
                                 QoSProfile(depth=1000))
    node.create_subscription(CableStates, "cable_states", on_cables, QoSProfile(depth=1000))
    cmd = node.create_publisher(CableCommand, "cable_commands", 10)
    wait_for_matches([cmd], 1, 30, poll=lambda s: ex.spin_once(timeout_sec=s))
    cmd.publish(CableCommand(name=["long1", "long2", "long3"], rest_length=COMMAND))   # held from the start
    play = node.create_client(SetSimulationState, "set_simulation_state")
    play.wait_for_service(timeout_sec=30)
    request = SetSimulationState.Request()
    request.state.state = SimulationState.STATE_PLAYING
    assert spin_until_done(ex, play.call_async(request), 30)
    end = time.monotonic() + 60.0
    while not first and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.05)
    assert first, "the command never took effect"
    start = len(seen)
    while time.monotonic() < seen[start - 1][0] + duration:
        ex.spin_once(timeout_sec=0.05)
    ex.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=rctx)
    _stop(sim)
    (w0, k0), (w1, k1) = seen[start - 1], seen[-1]
    node_step = (w1 - w0) / (k1 - k0)
    core = CoreMirror(first[0])
    core.run(k0)                                   # the same steps up to the window's start
    core_step = core.run(k1 - k0)                  # ... and the window's
    return [
        Row("general_ros", "free-running real-time factor (core)", 0.01 / core_step, "x",
            note=f"step + observation {core_step * 1e3:.2f} ms, steps {k0}..{k1}"),
        Row("general_ros", "free-running real-time factor (node)", 0.01 / node_step, "x",
            baseline="free-running real-time factor (core)", target="ratio <= 1.25 (>= 0.8 of the core's)",
            note=f"as fast as possible, steps {k0}..{k1} in {w1 - w0:.1f} s; joint_states {got['joint_states']}, "
                 f"body_states {got['body_states']} received"),
    ]


def _loops(env: dict, n: int, rounds: int) -> tuple[list, list, list]:
    """Seconds per bare ping-pong round trip, per lockstep step and per step of the core
    mirroring it, in alternating runs."""
    from tensegrity_msgs.msg import CableCommand

    loop = LockstepLoop(env, [f"scene:={SCENE}", "step_size:=0.01", "publish_rate:=100.0", "state_rate:=100.0",
                              "marker_rate:=0.0"],
                        n=n, joints=["long1", "long2", "long3"], command_type=CableCommand,
                        command_topic="cable_commands",
                        answer=lambda: CableCommand(name=["long1", "long2", "long3"], rest_length=COMMAND))
    core = CoreMirror()
    bare, steps, mirror = [], [], []
    for r in range(rounds + 1):
        b, s_, c = loop.ping_pong(), loop.lockstep(), core.run(n)
        if r:                              # the first round warms up
            bare.append(b)
            steps.append(s_)
            mirror.append(c)
    loop.close()
    return bare, steps, mirror


@benchmark
def lockstep_loop(ctx: Context) -> list[Row]:
    env = _env()
    n, rounds = (20, 1) if ctx.quick else (200, 5)
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    bare, loop, mirror = _loops(env, n, rounds)
    b, s_, c = statistics.median(bare), statistics.median(loop), statistics.median(mirror)
    added = statistics.median(x - y for x, y in zip(loop, mirror))
    return [
        Row("general_ros", "core step + observation (the same steps)", c * 1e3, "ms"),
        Row("general_ros", "bare rclpy ping-pong round trip", b * 1e3, "ms"),
        Row("general_ros", "lockstep step (state out, cable command in, one step)", s_ * 1e3, "ms",
            baseline="core step + observation (the same steps)",
            note=f"{1 / s_:.0f} steps/s; median of {rounds} runs of {n}"),
        Row("general_ros", "lockstep: added to the core's step", added * 1e3, "ms",
            baseline="bare rclpy ping-pong round trip", target="ratio >= 0.5 (<= 2 round trips)",
            note="per run: lockstep step - core step of the same steps; median"),
    ]
