"""``tensegrity_formfind``: the ``find_form`` service over the core's form-finding.

The request carries a structure description as *text* (YAML, JSON or TOML, the
structure-file format of ``docs/structures.md``; how the format is told: docs/ros.md); the
service never reads a file or a shipped example, whatever the text says. Each request is
solved in its own worker process (forked from a forkserver with the numerical core
preloaded), at most ``max_workers`` at once; the service callbacks run in a reentrant
callback group on a multi-threaded executor, so a long request never blocks other callers.
Every request is bounded: its size (``max_request_bytes``) before anything else, its
nesting, aliases and members (``max_members``) while it is parsed, its time (``time_limit``,
from the worker's start, parsing included) and its memory (``max_worker_memory_mb``, the
worker's address space). Malformed, oversized, over-limit or non-converging requests get
``success = false`` and a short reason (values quoted in a few dozen characters at most)
that says which phase a time limit hit.
"""

from __future__ import annotations

import math
import multiprocessing
import sys
import threading
import time
from collections.abc import Sequence
from multiprocessing import resource_tracker
from multiprocessing.process import BaseProcess
from typing import Any, cast

from geometry_msgs.msg import Point
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from tensegrity_msgs.srv import FindForm

from tensegrity_core.schema import Limits, clip
from tensegrity_ros.nodes import formfind_worker
from tensegrity_ros.nodes.common import SERVICE_QOS, declare, spin_node
from tensegrity_ros.nodes.formfind_worker import FormFindReply
from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services
from tensegrity_ros.rclpy_utils.stop_signals import signals_blocked

#: What the workers' forkserver imports before it forks them: the modules a request runs
#: (``tensegrity_core.general`` exports its names lazily, so the package alone holds none of
#: them, and every worker would import form-finding and scipy.optimize itself: ~0.5 s of CPU a
#: request).
WORKER_PRELOAD = ["tensegrity_ros.nodes.formfind_worker", "tensegrity_core.general.formfind",
                  "tensegrity_core.general.loading"]
_CTX = multiprocessing.get_context("forkserver")
_CTX.set_forkserver_preload(WORKER_PRELOAD)
#: How long a form-finding worker may run past the time limit to stop itself at its next
#: iteration and send what it has (a parsing worker is stopped at the limit itself) [s].
GRACE = 2.0
#: How long a worker may take to start (the first one also starts the forkserver, which
#: imports the core) before the time limit starts counting [s].
STARTUP_LIMIT = 60.0
#: How much of a worker's failure message goes into the node's log (characters).
LOG_CHARS = 200


class FormFindNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("tensegrity_formfind", **kwargs)
        guard_parameter_services(self)
        self.max_workers = declare(self, "max_workers", 2, "form-findings run at once [processes]",
                                   lo=1, hi=64, read_only=True)
        self.time_limit = declare(self, "time_limit", 60.0, "wall-time limit per request, parsing included [s]",
                                  lo=0.1, read_only=True)
        self.max_request_bytes = declare(self, "max_request_bytes", 4_000_000,
                                         "largest structure description accepted [bytes]", lo=1, read_only=True)
        self.max_members = declare(self, "max_members", 50_000, "largest structure accepted [members]", lo=1,
                                   read_only=True)
        self.max_worker_memory_mb = declare(self, "max_worker_memory_mb", 2048,
                                            "memory a worker may take beyond the preloaded core [MiB]", lo=64,
                                            read_only=True)
        self.limits = Limits(max_bytes=self.max_request_bytes)
        self._slots = threading.BoundedSemaphore(self.max_workers)
        self._workers_lock = threading.Lock()    # worker start vs. shutdown
        self._closing = threading.Event()       # set under the lock by destroy_node
        self.create_service(FindForm, "find_form", self.on_request, qos_profile=SERVICE_QOS,
                            callback_group=ReentrantCallbackGroup())
        self.get_logger().info(f"find_form ready ({self.max_workers} workers, time limit {self.time_limit:g} s)")

    def on_request(self, req: FindForm.Request, res: FindForm.Response) -> FindForm.Response:
        res.success = False
        size = len(req.structure.encode("utf-8", "surrogatepass"))
        if size > self.max_request_bytes:
            res.message = (f"structure description is {size} bytes, more than max_request_bytes = "
                           f"{self.max_request_bytes}")
            return res
        if not req.structure.strip():
            res.message = "empty structure description"
            return res
        if not 0.0 <= req.tolerance < math.inf:
            res.message = f"tolerance must be a finite number >= 0 (0 = default), got {req.tolerance}"
            return res
        with self._slots:
            out = self._run(req.structure, float(req.tolerance), int(req.max_iterations))
        res.success = out.success
        res.message = out.message
        res.nodes = [Point(x=p[0], y=p[1], z=p[2]) for p in out.nodes]
        res.member_forces = out.member_forces
        res.iterations = out.iterations
        res.residual = out.residual
        res.residual_norm = out.residual_norm
        res.min_stiffness_eigenvalue = out.min_stiffness_eigenvalue
        res.stability_margin = out.stability_margin
        if not res.success:
            first = res.message.splitlines()[0] if res.message else ""
            self.get_logger().warning(f"find_form failed: {clip(first, LOG_CHARS)}")
        return res

    def _run(self, text: str, tol: float, max_iter: int) -> FormFindReply:
        """Solve in a worker; stop it at the time limit, which counts from the worker's first
        report (form-finding: after a short grace for its own stop), and say in which phase."""
        time_limit = self.time_limit
        parent, child = _CTX.Pipe(duplex=False)
        proc = _CTX.Process(target=formfind_worker.run, daemon=True,
                            args=(child, text, tol, max_iter, time_limit, self.max_members, self.limits,
                                  self.max_worker_memory_mb * 2**20))
        if not self._start_worker(proc):
            parent.close()
            child.close()
            return FormFindReply.failure("the form-finding node is shutting down")
        child.close()
        phase, start = "starting the worker", None
        try:
            while True:
                if start is None:
                    end = time.monotonic() + STARTUP_LIMIT
                else:
                    end = start + time_limit + (GRACE if phase == formfind_worker.FORM_FINDING else 0.0)
                if not parent.poll(max(0.0, end - time.monotonic())):
                    limit = time_limit if start is not None else STARTUP_LIMIT
                    return FormFindReply.failure(
                        f"time limit of {limit:g} s reached while {phase}; the worker was stopped")
                kind, value = parent.recv()
                if kind == "result":
                    return cast(FormFindReply, value)      # what the worker sends as its result
                phase = value
                start = time.monotonic() if start is None else start
        except EOFError:
            proc.join(timeout=5)
            if proc.exitcode == formfind_worker.OVER_MEMORY_EXIT:
                return FormFindReply.failure(formfind_worker.OVER_MEMORY)
            return FormFindReply.failure(
                f"the form-finding worker died while {phase} (exit code {proc.exitcode}; its memory is capped "
                f"at max_worker_memory_mb = {self.max_worker_memory_mb})")
        finally:
            parent.close()
            if proc.is_alive():
                proc.kill()
            proc.join(timeout=5)

    def _start_worker(self, proc: BaseProcess) -> bool:
        """Start worker process ``proc``, unless the node is shutting down (then False).

        Not under the lock: the first start waits for the forkserver to import its preloads
        (seconds on a loaded machine), and a stop must not wait for that. A worker whose
        start ends after :meth:`destroy_node` looked is killed here.

        SIGINT and SIGTERM are blocked while it starts, so the forkserver (started by the
        first worker) and every worker it forks keep them blocked: a stop of ``tensegrity
        up`` signals the node's whole process group, and a forkserver still importing its
        preloads printed a ``KeyboardInterrupt`` traceback (Python ignores SIGINT there only
        once the preloads are in). The node kills its workers itself as it stops, and the
        forkserver ends with the node's process. The resource tracker is started before
        the block: starting it unblocks both signals in the calling thread (CPython 3.11's
        ``resource_tracker.ensure_running`` blocks them around its spawn, then unblocks
        instead of restoring the mask), which would undo the block before the forkserver's
        spawn."""
        with self._workers_lock:
            if self._closing.is_set():
                return False
        resource_tracker.ensure_running()
        with signals_blocked():
            proc.start()
        with self._workers_lock:
            if not self._closing.is_set():
                return True
        proc.kill()
        proc.join(timeout=5)
        return False

    def destroy_node(self) -> None:
        """Kill the running workers first: their requests end at once ("worker died"), so
        a shutdown never waits for a form-finding to finish, and start no new ones."""
        with self._workers_lock:
            self._closing.set()
            for proc in multiprocessing.active_children():
                proc.kill()
        super().destroy_node()  # type: ignore[no-untyped-call]  # rclpy's, through super(): not excluded by name


def main(argv: Sequence[str] | None = None) -> int:
    return spin_node(FormFindNode, argv, executor_factory=lambda: MultiThreadedExecutor(num_threads=16))


if __name__ == "__main__":
    sys.exit(main(sys.argv))
