"""Many ``tensegrity`` commands as processes for the price of one interpreter start.

A ``tensegrity`` process spends ~1.2-1.6 s of CPU importing numpy, scipy, rclpy and the
interfaces before it looks at its arguments; a test of twenty refused commands paid that
twenty times. Here one interpreter (this module, run with ``python -m tests.forked_cli``)
imports them once, then forks one child per command: each child is a process of its own
(its own signal handling, rclpy context, file descriptors, exit status and interpreter
exit, as the ``tensegrity`` console script gives it: :func:`tensegrity_ros.cli.run`), only
its imports were done before the fork. The children run at once, as the commands did when
each was started by itself. ``os.fork`` is used directly (multiprocessing's fork start
method wraps the child's exit and output, which are what is tested); the parent holds no
thread and no ROS context when it forks.

Protocol: stdin a JSON object ``{"cases": [[arg, ...], ...], "cwd": path, "timeout": s}``;
stdout a JSON list, one ``{"returncode", "stdout", "stderr"}`` per case, in order (the
return code as :mod:`subprocess` gives it: ``-N`` for a signal). A child still running after
``timeout`` seconds is killed (SIGKILL: ``-9``).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve()


def run_all(cases: list[list[str]], cwd: Path | str, timeout: float = 180.0) -> list[subprocess.CompletedProcess]:
    """Run every ``tensegrity`` command of ``cases`` in ``cwd``, each in a process of its own
    (forked from one interpreter), all at once; each one's completed process, in order."""
    request = json.dumps({"cases": cases, "cwd": str(cwd), "timeout": timeout})
    done = subprocess.run([sys.executable, "-m", "tests.forked_cli"], input=request, capture_output=True, text=True,
                          cwd=HERE.parents[1], timeout=timeout + 60)
    assert done.returncode == 0, done.stderr
    return [subprocess.CompletedProcess(args, r["returncode"], r["stdout"], r["stderr"])
            for args, r in zip(cases, json.loads(done.stdout), strict=True)]


def _child(args: list[str], cwd: str, out: int, err: int) -> None:
    """In the forked child: the process of ``tensegrity *args`` (never returns: ``run``
    exits, and the exit unwinds through the caller to the interpreter's own exit)."""
    from tensegrity_ros.cli import run

    os.chdir(cwd)
    devnull = os.open(os.devnull, os.O_RDONLY)
    for fd, target in ((devnull, 0), (out, 1), (err, 2)):
        os.dup2(fd, target)
    sys.argv = ["tensegrity", *args]
    run()


def _main() -> None:
    request = json.loads(sys.stdin.read())
    import numpy  # noqa: F401  (the imports every command pays, paid once here)
    import rclpy  # noqa: F401
    import scipy.linalg  # noqa: F401

    import tensegrity_ros.cli  # noqa: F401

    # no context manager or finally around the forks: a child's exit unwinds through here
    tmp = tempfile.mkdtemp(prefix="forked_cli_")
    children = []
    for i, args in enumerate(request["cases"]):
        paths = (Path(tmp) / f"{i}.out", Path(tmp) / f"{i}.err")
        fds = [os.open(p, os.O_WRONLY | os.O_CREAT, 0o600) for p in paths]
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            _child(args, request["cwd"], *fds)    # SystemExit leaves through here, in the child only
        for fd in fds:
            os.close(fd)
        children.append((pid, paths))
    deadline = time.monotonic() + request["timeout"]
    results = []
    for pid, paths in children:
        while (waited := os.waitpid(pid, os.WNOHANG))[0] == 0 and time.monotonic() < deadline:
            time.sleep(0.02)
        if waited[0] == 0:
            os.kill(pid, signal.SIGKILL)
            waited = os.waitpid(pid, 0)
        results.append({"returncode": os.waitstatus_to_exitcode(waited[1]),
                        "stdout": paths[0].read_text(errors="replace"),
                        "stderr": paths[1].read_text(errors="replace")})
    shutil.rmtree(tmp)
    json.dump(results, sys.stdout)


if __name__ == "__main__":
    _main()
