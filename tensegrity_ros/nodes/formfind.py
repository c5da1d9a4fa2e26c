"""``tensegrity_formfind``: the ``find_form`` service over the core's form-finding.

The request carries a structure description (YAML, the structure-file format of
``docs/structures.md``). Each request is solved in its own worker process (forked from a
forkserver with the numerical core preloaded), at most ``max_workers`` at once; the
service callbacks run in a reentrant callback group on a multi-threaded executor, so a
long request never blocks other callers, and a request over ``time_limit`` is stopped.
Malformed, oversized or non-converging requests get ``success = false`` and a reason.
"""

from __future__ import annotations

import multiprocessing
import sys
import threading

from tensegrity_ros.nodes.common import SERVICE_QOS, declare, rclpy, spin_node
from geometry_msgs.msg import Point
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from tensegrity_msgs.srv import FindForm

from tensegrity_ros import formfind_worker

_CTX = multiprocessing.get_context("forkserver")
_CTX.set_forkserver_preload(["tensegrity_ros.formfind_worker", "tensegrity_core.general"])


def _child(conn, *args) -> None:
    try:
        conn.send(formfind_worker.solve(*args))
    finally:
        conn.close()


class FormFindNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("tensegrity_formfind", **kwargs)
        self.max_workers = declare(self, "max_workers", 2, "form-findings run at once (processes)",
                                   lo=1, hi=64, read_only=True)
        self.time_limit = declare(self, "time_limit", 60.0, "wall-time limit per request [s]", lo=0.1, read_only=True)
        self.max_request_bytes = declare(self, "max_request_bytes", 4_000_000,
                                         "largest structure description accepted [bytes]", lo=1, read_only=True)
        self.max_members = declare(self, "max_members", 50_000, "largest structure accepted [members]", lo=1, read_only=True)
        self._slots = threading.BoundedSemaphore(self.max_workers)
        self._workers_lock = threading.Lock()    # worker start vs. shutdown
        self._closing = False
        self.create_service(FindForm, "find_form", self.on_request, qos_profile=SERVICE_QOS,
                            callback_group=ReentrantCallbackGroup())
        self.get_logger().info(f"find_form ready ({self.max_workers} workers, time limit {self.time_limit:g} s)")

    def on_request(self, req: FindForm.Request, res: FindForm.Response) -> FindForm.Response:
        res.success = False
        size = len(req.structure.encode())
        if size > self.max_request_bytes:
            res.message = (f"structure description is {size} bytes, more than max_request_bytes = "
                           f"{self.max_request_bytes}")
            return res
        if not req.structure.strip():
            res.message = "empty structure description"
            return res
        if req.tolerance < 0 or req.tolerance != req.tolerance:
            res.message = f"tolerance must be >= 0 (0 = default), got {req.tolerance}"
            return res
        time_limit, max_members = self.time_limit, self.max_members
        with self._slots:
            out = self._run(req.structure, float(req.tolerance), int(req.max_iterations), time_limit, max_members)
        res.success = bool(out["success"])
        res.message = out["message"]
        res.nodes = [Point(x=p[0], y=p[1], z=p[2]) for p in out["nodes"]]
        res.member_forces = out["member_forces"]
        res.iterations = out["iterations"]
        res.residual = out["residual"]
        res.min_stiffness_eigenvalue = out["min_stiffness_eigenvalue"]
        if not res.success:
            self.get_logger().warning(f"find_form failed: {res.message.splitlines()[0] if res.message else ''}")
        return res

    def _run(self, text: str, tol: float, max_iter: int, time_limit: float, max_members: int) -> dict:
        parent, child = _CTX.Pipe(duplex=False)
        proc = _CTX.Process(target=_child, args=(child, text, tol, max_iter, time_limit, max_members), daemon=True)
        if not self._start_worker(proc):
            parent.close()
            child.close()
            return _failure("the form-finding node is shutting down")
        child.close()
        grace = time_limit + 10.0  # the worker stops itself at time_limit; this is the backstop
        try:
            if parent.poll(grace):
                return parent.recv()
            return _failure(f"form-finding exceeded the time limit of {time_limit:g} s and was stopped")
        except EOFError:
            return _failure(f"form-finding worker died (exit code {proc.exitcode})")
        finally:
            parent.close()
            if proc.is_alive():
                proc.kill()
            proc.join(timeout=5)

    def _start_worker(self, proc) -> bool:
        """Start worker process ``proc``, unless the node is shutting down (then False)."""
        with self._workers_lock:
            if self._closing:
                return False
            proc.start()
            return True

    def destroy_node(self) -> None:
        """Kill the running workers first: their requests end at once ("worker died"), so
        a shutdown never waits for a form-finding to finish, and start no new ones."""
        with self._workers_lock:
            self._closing = True
            for proc in multiprocessing.active_children():
                proc.kill()
        super().destroy_node()


def _failure(message: str) -> dict:
    nan = float("nan")
    return {"success": False, "message": message, "nodes": [], "member_forces": [],
            "iterations": 0, "residual": nan, "min_stiffness_eigenvalue": nan}


def main(argv=None) -> int:
    return spin_node(FormFindNode, argv, executor_factory=lambda: MultiThreadedExecutor(num_threads=16))


if __name__ == "__main__":
    sys.exit(main(sys.argv))
