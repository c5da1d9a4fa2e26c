"""Benchmarks of ``tensegrity_sim`` on a robot (``python -m tests.bench --only robot_ros``).

The 6-bar robot, step 1 ms (the robot back end's own fixed step: one integrator step per
simulator step). Each ROS figure is set against the core in this process, in the same run:

1. Free-running as fast as possible (``six_bar_roll``: the shipped gait rolls it, no
   commands), publishing joint_states (24 motor cables), body_states, cable_states (every
   member), one sensor_msgs/Imu per rod (6) and /clock at 100 Hz of simulated time: the
   simulated seconds the node made per wall second in a window, against the core's
   ``set_command`` + ``advance`` of the same steps with one ``observe`` per 10 steps (what
   the node does per publication). Claims: real-time factor >= 5 and >= 0.8 of the core's.
   Beside them: the simulator process's CPU per step over the window (every thread: DDS's
   too) against the core's, a ratio the load distorts less than the real-time factors'.
2. Lockstep (``six_bar_drop``: every motor commanded): ``StepSimulation(N)`` while a client
   in this process answers every joint state with a ``CableCommand`` of the 24 rest lengths
   stamped like it, alternating with a bare rclpy ping-pong (:mod:`.lockstep_loop`), and the
   core making the same steps with a joint sample each (what the node publishes joint_states
   from). Claims: >= 500 steps/s and >= 0.7 of the ping-pong. Beside the means: the median
   time between two answers at the client and the CPU per exchange of the simulator and of
   the echo (what a busy machine distorts less than the means).

The free-running figures are measured one after the other (the node's window, then the
core's same steps), so a change of the machine's load between them moves their ratio; the
lockstep ones alternate.

Quick mode (CI's smoke run: every row reported, no speed proven): 0.5 s free-running, 1 x 20
lockstep steps (after a warm-up run); full mode: 15 s, 5 x 500 steps.
"""

from __future__ import annotations

import statistics
import time

from tests.bench.bench_ros import _env, _start, _stop
from tests.bench.harness import Context, Row, benchmark
from tests.bench.lockstep_loop import LockstepLoop, process_cpu_s, ros_client

STEP_NS = 1_000_000
#: Steps per publication at 100 Hz of simulated time.
PER_PUBLICATION = 10
HOLD = 0.75            # the lockstep controller's rest lengths [m], inside the motors' range


class CoreMirror:
    """The core stepping ``scene`` as the node does, observing every ``every`` steps (a full
    observation, or with ``joints_only`` the joint sample a lockstep publication of
    joint_states alone takes)."""

    def __init__(self, scene: str, every: int, *, joints_only: bool = False):
        from tensegrity_core.sim import Simulator

        self.sim = Simulator(scene)
        self.every = every
        self.observe = self.sim.joint_sample if joints_only else self.sim.observe
        self.command = [0.0 if c != c else c for c in self.sim.command]     # laws: placeholders
        self.k = 0

    def run(self, n: int, command: list[float] | None = None) -> float:
        """Make ``n`` steps (under ``command`` or the held one); seconds per step."""
        from tensegrity_core.sim.sampled import step_time

        t0 = time.perf_counter()
        for _ in range(n):
            self.sim.set_command(command or self.command)
            self.k += 1
            self.sim.advance(step_time(self.k, STEP_NS))
            if self.k % self.every == 0:
                self.observe()
        return (time.perf_counter() - t0) / n


@benchmark
def free_running(ctx: Context) -> list[Row]:
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import Imu, JointState
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import SetSimulationState
    from tensegrity_msgs.msg import CableStates

    from tensegrity_ros.rclpy_utils.futures import spin_until_done

    env = _env()
    duration = 0.5 if ctx.quick else 15.0
    sim = _start(["node", "sim", "--ros-args", "-p", "scene:=six_bar_roll", "-p", "real_time_factor:=0.0",
                  "-p", "publish_rate:=100.0", "-p", "step_size:=0.001", "-p", "state_rate:=100.0",
                  "-p", "imu_rate:=100.0", "-p", "marker_rate:=0.0", "-p", "initial_state:=paused",
                  "-p", "paused_publish_rate:=0.0"], env, "publishing at")
    rclpy, rctx, node, ex = ros_client(env, "bench_robot_client")
    got = {"joint_states": 0, "imu/rod0": 0}
    seen: list[tuple[float, int]] = []      # (wall time, step) of each cable_states

    def on_cables(msg) -> None:
        seen.append((time.monotonic(), (msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec) // STEP_NS))

    for topic, kind in (("joint_states", JointState), ("imu/rod0", Imu)):
        node.create_subscription(kind, topic, lambda _m, t=topic: got.__setitem__(t, got[t] + 1),
                                 QoSProfile(depth=1000))
    node.create_subscription(CableStates, "cable_states", on_cables, QoSProfile(depth=1000))
    play = node.create_client(SetSimulationState, "set_simulation_state")
    play.wait_for_service(timeout_sec=30)
    request = SetSimulationState.Request()
    request.state.state = SimulationState.STATE_PLAYING
    assert spin_until_done(ex, play.call_async(request), 30)
    end = time.monotonic() + 60.0
    while len(seen) < 20 and time.monotonic() < end:        # past the start
        ex.spin_once(timeout_sec=0.05)
    assert len(seen) >= 20, "the simulator never published"
    start = len(seen)
    cpu0 = process_cpu_s(sim.pid)
    while time.monotonic() < seen[start - 1][0] + duration:
        ex.spin_once(timeout_sec=0.05)
    cpu1, last = process_cpu_s(sim.pid), len(seen)
    ex.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=rctx)
    _stop(sim)
    (w0, k0), (w1, k1) = seen[start - 1], seen[last - 1]
    node_rtf = (k1 - k0) * STEP_NS / 1e9 / (w1 - w0)
    node_cpu = (cpu1 - cpu0) / (k1 - k0)
    core = CoreMirror("six_bar_roll", PER_PUBLICATION)
    core.run(k0)                                   # the same steps up to the window's start
    cpu = time.thread_time()
    core_step = core.run(k1 - k0)                  # ... and the window's
    core_cpu = (time.thread_time() - cpu) / (k1 - k0)
    core_rtf = STEP_NS / 1e9 / core_step
    return [
        Row("robot_ros", "6-bar free-running real-time factor (core)", core_rtf, "x",
            note=f"1 ms steps, an observation per 10; steps {k0}..{k1}"),
        Row("robot_ros", "6-bar free-running real-time factor (node)", node_rtf, "x",
            baseline="6-bar free-running real-time factor (core)", target="ratio <= 1.25 (>= 0.8 of the core's)",
            note=f"as fast as possible, topics at 100 Hz of simulated time; steps {k0}..{k1} in {w1 - w0:.1f} s; "
                 f"joint_states {got['joint_states']}, imu/rod0 {got['imu/rod0']} received"),
        Row("robot_ros", "6-bar free-running real-time factor (node, absolute)", node_rtf, "x", target=">= 5"),
        Row("robot_ros", "6-bar free-running core CPU per step", core_cpu * 1e6, "us",
            note="this thread's CPU over the window's steps, an observation per 10"),
        Row("robot_ros", "6-bar free-running simulator process CPU per step", node_cpu * 1e6, "us",
            baseline="6-bar free-running core CPU per step",
            note="/proc over the window, every thread (DDS's too); a ratio the load distorts less than the "
                 "real-time factors'"),
    ]


@benchmark
def lockstep_loop(ctx: Context) -> list[Row]:
    from tensegrity_msgs.msg import CableCommand

    from tensegrity_core.robot.loading import load_robot

    env = _env()
    n, rounds = (20, 1) if ctx.quick else (500, 5)
    r = load_robot("six_bar")
    motors = [r.cables.names[c] for c in r.motors.cable]
    loop = LockstepLoop(env, ["scene:=six_bar_drop", "step_size:=0.001", "publish_rate:=1000.0",
                              "state_rate:=0.0", "imu_rate:=0.0", "marker_rate:=0.0"],
                        n=n, joints=motors, command_type=CableCommand, command_topic="cable_commands",
                        answer=lambda: CableCommand(name=motors, rest_length=[HOLD] * len(motors)))
    core = CoreMirror("six_bar_drop", 1, joints_only=True)
    bare, steps, mirror, exchanges = [], [], [], []
    for i in range(rounds + 1):
        b = loop.ping_pong()
        pong = loop.last
        s_ = loop.lockstep()
        c = core.run(n, [HOLD] * len(motors))
        if i:                              # the first round warms up
            bare.append(b)
            steps.append(s_)
            mirror.append(c)
            exchanges.append((pong, loop.last))
    loop.close()
    b, s_, c = statistics.median(bare), statistics.median(steps), statistics.median(mirror)
    ratios = sorted(x / y for x, y in zip(bare, steps))
    gap_b = statistics.median(p.median_gap_s for p, _ in exchanges)
    gap_s = statistics.median(q.median_gap_s for _, q in exchanges)
    cpu_b = statistics.fmean(p.server_cpu_s for p, _ in exchanges)    # over every run: the clock ticks of
    cpu_s = statistics.fmean(q.server_cpu_s for _, q in exchanges)    # 10 ms need many steps
    return [
        Row("robot_ros", "6-bar core step + joint sample", c * 1e3, "ms"),
        Row("robot_ros", "bare rclpy ping-pong round trip (24 joints)", b * 1e3, "ms"),
        Row("robot_ros", "6-bar lockstep step (state out, cable command in, one step)", s_ * 1e3, "ms",
            baseline="bare rclpy ping-pong round trip (24 joints)", target="ratio >= 0.7",
            note=f"{1 / s_:.0f} steps/s; median of {rounds} runs of {n}; per-pair ratios "
                 f"{ratios[0]:.2f}..{ratios[-1]:.2f}"),
        Row("robot_ros", "6-bar lockstep steps per second", 1 / s_, "steps/s", target=">= 500"),
        Row("robot_ros", "bare ping-pong: median time between answers", gap_b * 1e3, "ms",
            note="at the client; a preempted exchange moves the mean, hardly the median"),
        Row("robot_ros", "6-bar lockstep: median time between states", gap_s * 1e3, "ms",
            baseline="bare ping-pong: median time between answers", note="a ratio the load distorts less than the means'"),
        Row("robot_ros", "echo process CPU per round trip", cpu_b * 1e6, "us", note="/proc, mean over the runs"),
        Row("robot_ros", "simulator process CPU per lockstep step", cpu_s * 1e6, "us",
            baseline="echo process CPU per round trip", note="/proc, mean over the runs"),
    ]
