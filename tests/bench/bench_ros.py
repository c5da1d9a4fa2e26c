"""Benchmarks of the ROS nodes (``python -m tests.bench --only ros [--full]``).

1. Simulator publishing: ``tensegrity node sim`` at publish_rate 1000 Hz, real time, the
   paper's mechanism; a subscriber in this process notes the rmw receive time of every joint
   state.
   Reported: achieved rate against the requested one (ratio), arrival jitter (std and 99th
   percentile of the inter-arrival deviation from 1 ms), and the simulated-time spacing.
2. The recorder at that load: ``tensegrity record`` beside the 1 kHz simulator (with the
   full state at 1 kHz and markers at 30 Hz); the recorder's counts against the counts the
   simulator reports on shutdown. Claim: equal (no message dropped).
3. ``solve_ik`` round trip over DDS: 1,000 sequential calls from a client in this process;
   median and 99th percentile, against a bare rclpy service (std_srvs/Trigger answered at
   once, same client code) measured in the same run: the ratio is what the IK node adds
   to what DDS and rclpy cost on this machine. The in-process IK time is shown too.

Quick mode (CI's smoke run: every row reported, no speed proven): 0.5 s of publishing at
1 kHz with the recorder on, 50 calls after the 20 warm-up calls; full mode: 10 s, 1,000 calls.
"""

from __future__ import annotations

import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tests.bench.harness import Context, Row, benchmark, time_per_call

TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))


def _env() -> dict:
    env = dict(os.environ)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return env


def _start(args: list[str], env: dict, ready: str) -> subprocess.Popen:
    proc = subprocess.Popen([TENSEGRITY, *args], env=env, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    for line in proc.stderr:
        if ready in line:
            return proc
        if time.monotonic() > deadline:
            break
    raise RuntimeError(f"{args} did not become ready")


def _stop(proc: subprocess.Popen) -> str:
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    return err


@benchmark
def sim_publishing_and_recorder(ctx: Context) -> list[Row]:
    with tempfile.TemporaryDirectory(prefix="bench_ros_") as tmp:
        return _measure_publishing_and_recording(ctx, Path(tmp) / "bag")


def _measure_publishing_and_recording(ctx: Context, folder: Path) -> list[Row]:
    import rclpy
    from rclpy.context import Context as RosContext
    from rclpy.qos import QoSProfile
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    from tensegrity_ros.rclpy_utils.raw_take import take_all

    env = _env()
    duration = 0.5 if ctx.quick else 10.0
    rec = _start(["record", "-o", str(folder)], env, "recording to")
    # the simulator starts its clock only once the recorder (and the probe below) listen,
    # so every message it publishes can be counted at the recorder
    sim = _start(["node", "sim", "--ros-args", "-p", "publish_rate:=1000.0", "-p", "state_rate:=1000.0",
                  "-p", "marker_rate:=30.0", "-p", "wait_for_subscribers:=1"], env, "publishing at")
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    rctx = RosContext()
    rclpy.init(args=[], context=rctx)
    node = rclpy.create_node("bench_rate_probe", context=rctx)
    arrivals: list[int] = []
    stamps: list[float] = []
    # rmw receive times, taken straight from the subscription every 5 ms (as the recorder
    # does): an executor callback per message would lag at 1 kHz and time the backlog
    sub = node.create_subscription(JointState, "joint_states", lambda *_: None, QoSProfile(depth=1000),
                                   raw=True)
    end, started = time.monotonic() + 60.0, False  # until `duration` s after the first message
    while time.monotonic() < end:
        if arrivals and not started:
            end, started = time.monotonic() + duration, True
        for data, info in take_all(sub):
            arrivals.append(info["received_timestamp"])
            stamp = deserialize_message(data, JointState).header.stamp
            stamps.append(stamp.sec + 1e-9 * stamp.nanosec)
        time.sleep(0.005)
    node.destroy_node()
    rclpy.try_shutdown(context=rctx)
    sim_log = _stop(sim)
    time.sleep(1.0)
    _stop(rec)

    a = np.array(arrivals[len(arrivals) // 10:], dtype=float) * 1e-9   # skip the discovery transient
    gaps = np.diff(a)
    rate = (len(a) - 1) / (a[-1] - a[0])
    dev = np.abs(gaps - 1e-3)
    sim_gaps = np.diff(np.array(stamps[len(stamps) // 10:]))
    rows = [
        Row("ros", "sim requested joint_states rate", 1000.0, "Hz"),
        Row("ros", "sim achieved joint_states rate", rate, "Hz", baseline="sim requested joint_states rate",
            target="ratio ~1.0 (sustains 1 kHz)"),
        Row("ros", "sim arrival jitter std", float(np.std(gaps)) * 1e3, "ms"),
        Row("ros", "sim arrival |gap - 1 ms| p99", float(np.percentile(dev, 99)) * 1e3, "ms"),
        Row("ros", "sim simulated-time gap median", float(np.median(sim_gaps)) * 1e3, "ms"),
    ]
    published = {}
    m = re.search(r"published: (.*?); rejected", sim_log)
    if m:
        for part in m.group(1).split(", "):
            name, count = part.rsplit(" ", 1)
            published[name] = int(count)
    from tensegrity_ros.bag.metadata import read_metadata

    received = {t.name.lstrip("/") if t.name != "/clock" else t.name: t.message_count
                for t in read_metadata(folder).topics}
    for topic in ("joint_states", "mechanism_state", "markers"):
        dropped = published.get(topic, -1) - received.get(topic, 0)
        rows.append(Row("ros", f"recorder dropped {topic}", float(dropped), "msgs", target="== 0",
                        note=f"published {published.get(topic)} received {received.get(topic)}"))
    return rows


def _round_trips(srv_type, name: str, requests: list, env: dict) -> list[float]:
    import rclpy
    from rclpy.context import Context as RosContext
    from rclpy.executors import SingleThreadedExecutor

    from tensegrity_ros.rclpy_utils.futures import spin_until_done

    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    rctx = RosContext()
    rclpy.init(args=[], context=rctx)
    node = rclpy.create_node("bench_round_trip_client", context=rctx)
    client = node.create_client(srv_type, name)
    ex = SingleThreadedExecutor(context=rctx)
    ex.add_node(node)
    client.wait_for_service(timeout_sec=30)
    times = []
    for k, req in enumerate(requests[:20] + requests):          # 20 warm-up calls
        t0 = time.perf_counter()
        f = client.call_async(req)
        assert spin_until_done(ex, f, 10)
        if k >= 20:
            times.append(time.perf_counter() - t0)
    ex.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=rctx)
    return times


@benchmark
def ik_round_trip(ctx: Context) -> list[Row]:
    from std_srvs.srv import Trigger
    from tensegrity_msgs.srv import SolveIK

    from tensegrity_core.class2 import forward_kinematics, inverse_kinematics

    env = _env()
    n = 50 if ctx.quick else 1000
    echo = subprocess.Popen([sys.executable, "-m", "tests.bench.ros_echo_server"], env=env,
                            stdout=subprocess.PIPE, text=True)
    echo.stdout.readline()
    bare = _round_trips(Trigger, "bench_echo", [Trigger.Request() for _ in range(n)], env)
    echo.send_signal(signal.SIGINT)
    echo.wait(30)
    ik = _start(["node", "ik"], env, "solve_ik ready")
    targets = [forward_kinematics(0.3 + 0.4 * k / n, 0.6) for k in range(n)]
    times = _round_trips(SolveIK, "solve_ik", [SolveIK.Request(x=fk.x, y=fk.y) for fk in targets], env)
    _stop(ik)
    local = time_per_call(lambda: inverse_kinematics(targets[0].x, targets[0].y), min_time=0.1)
    return [
        Row("ros", "IK in-process (core)", local * 1e3, "ms"),
        Row("ros", "bare rclpy service round trip median", statistics.median(bare) * 1e3, "ms"),
        Row("ros", "bare rclpy service round trip p99", float(np.percentile(bare, 99)) * 1e3, "ms"),
        Row("ros", "solve_ik round trip median", statistics.median(times) * 1e3, "ms",
            baseline="bare rclpy service round trip median", target="< 2 ms", note=f"{n} sequential calls"),
        Row("ros", "solve_ik round trip p99", float(np.percentile(times, 99)) * 1e3, "ms",
            baseline="bare rclpy service round trip p99", target="< 10 ms"),
    ]
