"""What a hostile ``find_form`` request costs a real form-finding node (``python -m tests.bench
--only hostile [--full]``; issue 12).

One ``tensegrity node formfind`` with its defaults (time limit 60 s, requests up to 4 MB,
workers capped at 2 GiB beyond the preloaded core) is started as ``tensegrity up`` starts it
and called over DDS from a client in this process. Classes of request (the builders are
``tests/hostile_requests.py``, shared with ``tests/ros/test_formfind_hostile.py``):

- baseline: the shipped tensegrity table, which form-finds;
- a path as the structure text (``/etc/passwd``), which must be parsed as text;
- a YAML alias bomb of about 300 bytes standing for 43 million values;
- flow lists nested 100,000 deep;
- a 64 KiB value (the table with a 65,536-character ``units``);
- a tower of 60,000 members (1.4 MB), refused by its member count.

Reported per class: the answer time (call to response in this process, median over the
calls), the answer's size (the serialised response), the worker's peak resident memory
(``VmHWM`` of each worker process, read from ``/proc`` about every millisecond while the
call runs: the largest of the calls; a lower bound, as a worker can grow after its last
reading, and a worker that lives between two readings is not seen at all: the row says in
how many calls one was) and the node process's resident memory before the class's first call
and after its last (``VmRSS``; the row is the change; the last row, over all classes, is
held to the bound of ``test_the_node_returns_to_its_memory_baseline_after_bad_requests``).
The answer-time rows are compared with the baseline's, measured in the same run.

Quick mode: 3 calls per class (after 2 warm-up calls); full mode: 9 calls per class.
"""

from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tests.bench.harness import Context, Row, benchmark
from tests.hostile_requests import TABLE, alias_bomb, deep_flow_nesting, huge_value, memory_mib, tower_yaml
from tests.process_groups import exited, kill_group, wait_exited

TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))
BASELINE = "good request (tensegrity_table)"


def _classes() -> dict[str, str]:
    bomb = alias_bomb()
    return {
        BASELINE: TABLE,
        "path as text (/etc/passwd)": "/etc/passwd",
        f"alias bomb ({len(bomb)} B)": bomb,
        "nesting depth 100,000": deep_flow_nesting(100_000),
        "64 KiB value": huge_value(65536),
        "60,000 members (1.4 MB)": tower_yaml(60_000),
    }


def _parent_of(pid: int) -> int | None:
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return None


class _Descendants:
    """The processes below the node (its forkserver, the forkserver's workers), found by
    watching ``/proc`` for new pids; the peak memory each was seen with."""

    def __init__(self, root: int) -> None:
        self.root = root
        self.known = {int(p) for p in os.listdir("/proc") if p.isdigit()}
        self.tree = {root}
        self.peak: dict[int, float] = {}           # pid -> largest VmHWM seen [MiB]

    def poll(self) -> None:
        for name in os.listdir("/proc"):
            if name.isdigit() and (pid := int(name)) not in self.known:
                self.known.add(pid)
                if _parent_of(pid) in self.tree:
                    self.tree.add(pid)
        for pid in self.tree - {self.root}:
            try:
                hwm = memory_mib(pid).get("VmHWM")
            except OSError:
                continue
            if hwm is not None:
                self.peak[pid] = max(self.peak.get(pid, 0.0), hwm)


class _Caller:
    """A ``find_form`` client in this process that watches the node's workers while it waits."""

    def __init__(self, namespace: str, node_pid: int) -> None:
        import rclpy
        from rclpy.context import Context as RosContext
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile
        from tensegrity_msgs.srv import FindForm

        self._request = FindForm.Request
        self.ctx = RosContext()
        rclpy.init(args=[], context=self.ctx)
        self.node = rclpy.create_node("bench_hostile_client", context=self.ctx)
        self.client = self.node.create_client(FindForm, f"/{namespace}/find_form",
                                              qos_profile=QoSProfile(depth=10))
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        if not self.client.wait_for_service(timeout_sec=60):
            raise RuntimeError("find_form did not appear")
        self.processes = _Descendants(node_pid)

    def call(self, text: str, timeout: float = 180.0):
        """(seconds to the answer, the response, peak VmHWM of the worker(s) it started [MiB] or None)."""
        before = set(self.processes.tree)
        t0 = time.perf_counter()
        future = self.client.call_async(self._request(structure=text))
        while not future.done():
            if time.perf_counter() - t0 > timeout:
                raise RuntimeError("no answer")
            self.executor.spin_once(timeout_sec=0.0005)
            self.processes.poll()
        took = time.perf_counter() - t0
        self.processes.poll()
        workers = [self.processes.peak[p] for p in self.processes.tree - before
                   if p in self.processes.peak and not _is_forkserver(p)]
        return took, future.result(), max(workers) if workers else None

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def _is_forkserver(pid: int) -> bool:
    try:
        return b"multiprocessing.forkserver" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def _start_node(namespace: str, log: Path) -> subprocess.Popen:
    """``tensegrity node formfind`` as ``tensegrity up`` starts it, once it says it is ready."""
    from tensegrity_ros.rclpy_utils.stop_signals import signals_blocked

    with open(log, "w") as out, signals_blocked():
        proc = subprocess.Popen([TENSEGRITY, "node", "formfind", "--ros-args", "-r", f"__ns:=/{namespace}"],
                                stdout=out, stderr=out, env=dict(os.environ), start_new_session=True)
    deadline = time.monotonic() + 120
    while "find_form ready" not in log.read_text(errors="replace"):
        if exited(proc) or time.monotonic() > deadline:
            raise RuntimeError(f"the formfind node did not become ready: {log.read_text()[-500:]}")
        time.sleep(0.05)
    return proc


@benchmark
def hostile_requests(ctx: Context) -> list[Row]:
    from rclpy.serialization import serialize_message

    calls = 3 if ctx.quick else 9
    namespace = f"bench_hostile_{os.getpid()}"
    with tempfile.TemporaryDirectory() as tmp:
        proc = _start_node(namespace, Path(tmp) / "node.log")
        caller = None
        try:
            caller = _Caller(namespace, proc.pid)
            for _ in range(2):                  # starts the forkserver; the node's memory settles
                assert caller.call(TABLE)[1].success
            start_rss = memory_mib(proc.pid)["VmRSS"]
            rows = []
            for name, text in _classes().items():
                rss_before = memory_mib(proc.pid)["VmRSS"]
                results = [caller.call(text) for _ in range(calls)]
                node = memory_mib(proc.pid)
                times = [t for t, _, _ in results]
                res = results[-1][1]
                peaks = [p for _, _, p in results if p is not None]
                answer = "form-found" if res.success else f"refused: {res.message[:70]!r}"
                rows += [
                    Row("hostile", f"{name}: answer time, median", statistics.median(times), "s",
                        baseline=f"{BASELINE}: answer time, median" if name != BASELINE else None,
                        note=f"{calls} calls, max {max(times):.3g} s; request {len(text.encode())} B; {answer}"),
                    Row("hostile", f"{name}: answer size", len(serialize_message(res)), "B",
                        note=f"message {len(res.message)} characters"),
                    Row("hostile", f"{name}: worker peak RSS", max(peaks) if peaks else float("nan"), "MiB",
                        note=f"VmHWM, worker seen in {len(peaks)} of {calls} calls"),
                    Row("hostile", f"{name}: node RSS change", node["VmRSS"] - rss_before, "MiB",
                        note=f"VmRSS {rss_before:.1f} -> {node['VmRSS']:.1f} MiB, VmHWM {node['VmHWM']:.1f} MiB"),
                ]
            forkserver = [p for p in caller.processes.tree if _is_forkserver(p)]
            end = memory_mib(proc.pid)
            rows.append(Row("hostile", "node RSS change over all classes", end["VmRSS"] - start_rss, "MiB",
                            target="< 30 MiB",
                            note=f"VmRSS {start_rss:.1f} -> {end['VmRSS']:.1f} MiB, VmHWM {end['VmHWM']:.1f} MiB; "
                                 f"forkserver VmRSS {memory_mib(forkserver[0])['VmRSS']:.1f} MiB"
                                 if forkserver else ""))
            return rows
        finally:
            if caller is not None:
                caller.close()
            proc.send_signal(signal.SIGINT)
            try:
                wait_exited(proc, 30)
            finally:
                kill_group(proc)
