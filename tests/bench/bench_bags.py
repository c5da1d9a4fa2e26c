"""Benchmarks of the bag tools (``python -m tests.bench --only bags [--full]``).

1. Recorder throughput: ``tensegrity record`` (a subprocess) against the suite publishers
   (another process) at 1 kHz joint states, 100 Hz end effector, 100 Hz full state,
   30 Hz markers, 100 Hz /clock. Claim: received == published (0 dropped).
2. Replay timing: ``tensegrity play`` of that recording at rate 1 to a subscriber that
   notes the rmw receive time of each joint state. Claim: the median of
   |receive spacing - recorded spacing| is below 1 ms.

Quick mode records 0.5 s (500 joint states: as many spacings to judge); full mode 10 s.
"""

from __future__ import annotations

import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tests.bench.harness import Context, Row, benchmark

TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))
RATES = {"joint_states": 1000, "end_effector": 100, "mechanism_state": 100, "markers": 30,
         "/clock": 100}


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _record(folder: Path, duration: float, env: dict) -> tuple[dict, dict, float]:
    rec = subprocess.Popen([TENSEGRITY, "record", "-o", str(folder)], env=env,
                           stderr=subprocess.PIPE, text=True)
    pub = subprocess.run(
        [sys.executable, "-m", "tests.bags.suite_publishers", "--duration", str(duration),
         "--wait-subscribers", "60", *[f"--rate={t}={r}" for t, r in RATES.items()]],
        env=env, capture_output=True, text=True, timeout=duration + 120)
    cpu = _cpu_seconds(rec.pid)
    rec.send_signal(signal.SIGINT)
    rec.wait(120)
    published = json.loads(pub.stdout.strip().splitlines()[-1])["published"]
    from tensegrity_ros.bag.metadata import read_metadata

    received = {t.name.lstrip("/") if t.name != "/clock" else t.name: t.message_count
                for t in read_metadata(folder).topics}
    return published, received, cpu


def _replay_spacing_errors(folder: Path, env: dict) -> tuple[list[int], int]:
    import rclpy
    from rclpy.context import Context as RosContext
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState

    from tensegrity_ros.bag.reader import BagReader

    recorded = [m.log_time_ns for m in BagReader(folder).messages(["/joint_states"])]
    ctx = RosContext()
    rclpy.init(args=[], context=ctx)
    node = rclpy.create_node("timing_probe", context=ctx)
    arrivals: list[int] = []
    node.create_subscription(JointState, "/joint_states",
                             lambda _data, info: arrivals.append(info["received_timestamp"]),
                             QoSProfile(depth=1000), raw=True)
    play = subprocess.Popen([TENSEGRITY, "play", str(folder), "--topics", "joint_states",
                             "--wait-for-subscribers", "60"], env=env,
                            stderr=subprocess.DEVNULL)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    # until every message arrived, or the player has ended and nothing more came for a second
    # (a lost message is counted, not waited for); a guard against a hang besides
    deadline = time.monotonic() + 120 + (recorded[-1] - recorded[0]) / 1e9
    quiet_since, seen = time.monotonic(), 0
    while len(arrivals) < len(recorded) and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
        if len(arrivals) != seen or play.poll() is None:
            quiet_since, seen = time.monotonic(), len(arrivals)
        elif time.monotonic() - quiet_since > 1.0:
            break
    play.wait(60)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=ctx)
    n = min(len(arrivals), len(recorded))
    errors = [abs((arrivals[i] - arrivals[i - 1]) - (recorded[i] - recorded[i - 1]))
              for i in range(1, n)]
    return errors, len(recorded) - len(arrivals)


@benchmark
def bench_record_and_replay(ctx: Context) -> list[Row]:
    env = dict(os.environ)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.update(ROS_AUTOMATIC_DISCOVERY_RANGE=env["ROS_AUTOMATIC_DISCOVERY_RANGE"])
    duration = 0.5 if ctx.quick else 10.0
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "bench"
        published, received, cpu = _record(folder, duration, env)
        total_pub, total_rec = sum(published.values()), sum(received.values())
        dropped = sum(published[t] - received.get(t, 0) for t in published)
        errors, missing = _replay_spacing_errors(folder, env)
    errors_ms = sorted(e / 1e6 for e in errors)
    p95 = errors_ms[int(0.95 * (len(errors_ms) - 1))]
    return [
        Row("bags", "record: messages published", total_pub, "msgs",
            note=f"{duration:g} s at {RATES}"),
        Row("bags", "record: messages dropped", dropped, "msgs", target="== 0",
            note=f"received {total_rec}"),
        Row("bags", "record: recorder CPU", cpu / duration, "s/s",
            note="recorder process CPU time (start-up included) per second recorded"),
        Row("bags", "replay: median |spacing error|", statistics.median(errors_ms), "ms",
            target="< 1 ms", note=f"{len(errors_ms)} joint-state gaps, 1 ms recorded spacing"),
        Row("bags", "replay: p95 |spacing error|", p95, "ms"),
        Row("bags", "replay: messages not received", missing, "msgs", target="== 0"),
    ]
