"""Test-suite configuration shared by every test.

- DDS stays on loopback and each run uses its own ROS_DOMAIN_ID (set by ``./run test``;
  set here too so a bare ``pytest`` behaves the same).
- hypothesis: a derandomised profile without deadlines (the machines are shared and
  noisy, so no test may depend on wall time). ``HYPOTHESIS_PROFILE=dev`` explores more.
- No process outlives the run: every child inherits a mark of this run in its
  environment; at the end of the session any process still carrying it is killed and the
  run fails (a node left alive in a test domain could answer later tests' requests).
"""

from __future__ import annotations

import itertools
import os
import random
import signal
import time
import uuid
from pathlib import Path

os.environ.setdefault("ROS_DOMAIN_ID", str(100 + random.randrange(100)))
_BASE_DOMAIN = int(os.environ["ROS_DOMAIN_ID"])
os.environ.setdefault("MPLBACKEND", "Agg")
# BLAS on one thread in this run's processes and in every process they start (set before any
# of them loads OpenBLAS, numpy's and scipy's, which read it once as they load). The run's
# workers outnumber the cores (``./run test``: 6 on 2), so a second BLAS thread has no core of
# its own: every call handed to it waits for one, then spins on it (docs/design/general.md:
# a dense Newton step 4.1x the CPU and 7.2x the wall time on two threads; a 120 x 120 eigh
# 0.4 s instead of 2.8 ms under load; the class-2 LQR gain design's expm and Riccati solve
# ~50 ms a call instead of well under one). OPENBLAS_NUM_THREADS=N explores.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
_RUN_MARK = ("TENSEGRITY_TEST_RUN", f"{os.getpid()}-{uuid.uuid4().hex}")
os.environ[_RUN_MARK[0]] = _RUN_MARK[1]   # inherited by every process the run starts

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

from tensegrity_ros.rclpy_utils.env import ensure_ros_environment  # noqa: E402

ensure_ros_environment()   # loopback only, before this process or a child creates a context

# A suite started in the background from a script without job control inherits SIGINT as
# ignored, and so would every process it starts (an ignored signal stays ignored across exec):
# the tests that stop a process with Ctrl-C would all fail. A handler here resets to the default
# in each child at exec.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

settings.register_profile(
    "ci",
    derandomize=True,
    deadline=None,
    max_examples=200,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.register_profile("dev", deadline=None, max_examples=2000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def _same_examples_in_every_run() -> None:
    """A derandomised test must draw the same examples in every run. hypothesis also draws
    constants found in the local modules imported so far (``providers._get_local_constants``),
    and which modules those are depends on the tests a worker ran before: two fresh-clone runs
    with other orders drew other examples (the drawn-robot and class-2 IK edge cases). Under
    the ``ci`` profile that pool is left empty (hypothesis has no setting for it); ``dev``
    keeps it, to explore."""
    from hypothesis.internal.conjecture import providers

    if hasattr(providers, "_get_local_constants") and hasattr(providers, "Constants"):
        empty = providers.Constants()
        providers._get_local_constants = lambda: empty


if os.environ.get("HYPOTHESIS_PROFILE", "ci") == "ci":
    _same_examples_in_every_run()


def module_domain(index: int, worker: int, workers: int) -> int:
    """The ROS domain of the ``index``-th test module a worker runs: the run's base + an
    offset, interleaved between the run's parallel workers (worker ``w`` of ``n`` uses
    offsets ``w mod n``), so two modules running at once never share a domain. A worker's
    modules take the offsets in turn, ``230 // n`` of them, so a module never shares the
    domain of the modules just before it: a process killed there leaves its DDS participant
    matched for its lease (~20 s), and a publisher of the same topic waits for that reader's
    acknowledgements until its timeout (hashing the module's name into 29 offsets put up to 9
    modules in one domain). Valid domains are 0..232."""
    slots = 230 // workers
    return (_BASE_DOMAIN + (index % slots) * workers + worker) % 230 + 1


_modules_run = itertools.count()


@pytest.fixture(autouse=True, scope="module")
def _ros_domain_per_module(request):
    """Each test module talks in its own ROS domain, so a node that another module left
    shutting down, or another worker's module running at the same time, can never answer
    in its place."""
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw"))
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    previous = os.environ["ROS_DOMAIN_ID"]
    os.environ["ROS_DOMAIN_ID"] = str(module_domain(next(_modules_run), worker, workers))
    yield
    os.environ["ROS_DOMAIN_ID"] = previous


#: Test files whose tests are each a unit of work of their own for ``./run test``'s workers:
#: independent heavy tests (one subprocess each, no module fixture) that the workers share.
SHARED_FILES = ("tests/bench/test_quick_mode.py",)

#: Test files that are one unit of work together, named by what they share: a computation
#: cached in the process (``functools.lru_cache``), done once on the one worker that runs them
#: all. The sympy derivation of the class-2 dynamics (``studies.derivation.derive_dynamics``:
#: ``derive()`` ~3.4 s of CPU, which the first two files call, ``lambdified()`` ~1.5 s, which
#: the first and third call): the three files took 24.5 s of CPU in three processes, 13.9 s in one.
SAME_WORKER = {
    "tests/class2/test_dynamics_derivation.py": "the class-2 sympy derivation",
    "tests/class2/test_dynamics_paper_appendix.py": "the class-2 sympy derivation",
    "tests/sim/test_class2_effects.py": "the class-2 sympy derivation",
}


def pytest_collection_modifyitems(config, items):
    """Files with slow tests first (``./run test`` keeps this order: ``--no-loadscope-reorder``),
    so that no worker is left running a long file after the other ended."""
    slow = {item.nodeid.split("::", 1)[0] for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.nodeid.split("::", 1)[0] not in slow)   # stable: files stay whole


def work_unit(nodeid: str) -> str:
    """The unit of work of ``./run test``'s workers that the test ``nodeid`` belongs to: its
    file, but for :data:`SHARED_FILES` (the test alone) and :data:`SAME_WORKER` (the group)."""
    file = nodeid.split("::", 1)[0]
    return nodeid if file in SHARED_FILES else SAME_WORKER.get(file, file)


def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` (``./run test``): a test file is one unit of work, so its module
    fixtures start once, except the tests of :data:`SHARED_FILES`, each a unit of its own, and
    the files of :data:`SAME_WORKER`, one unit together."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class FileScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return work_unit(nodeid)

    return FileScheduling(config, log)


_PF_KTHREAD = 0x00200000   # a kernel thread's flag in /proc/<pid>/stat (include/linux/sched.h)


def _processes_of_this_run() -> tuple[dict[int, str], set[int]]:
    """(pid -> command line of every live process, other than this one, started by this run;
    pids of this run's descendants whose environment cannot be read yet).

    A process in the middle of exec (its parent's ``Popen`` has already returned) shows an
    empty environment until the kernel has built its new stack (measured: up to 20 ms on a
    loaded machine). Such a process whose parent is this one or a process of this run is not
    yet known to be outside the run, and is returned to be looked at again."""
    mark = f"{_RUN_MARK[0]}={_RUN_MARK[1]}".encode()
    found, ours, parent, unreadable = {}, {os.getpid()}, {}, []
    for entry in os.scandir("/proc") if os.path.isdir("/proc") else ():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        pid = int(entry.name)
        try:
            environ = Path(entry.path, "environ").read_bytes()
            # fields 3.. of stat: state, ppid, ..., flags at [6]
            stat = Path(entry.path, "stat").read_text().rsplit(")", 1)[1].split()
            if stat[0] == "Z":
                continue                  # exited, waiting to be reaped: not alive
            parent[pid] = int(stat[1])
            if not environ:
                if not int(stat[6]) & _PF_KTHREAD:
                    unreadable.append(pid)
                continue
            if mark not in environ.split(b"\0"):
                continue
            ours.add(pid)
            cmd = Path(entry.path, "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            if int(stat[1]) == os.getpid() and "from multiprocessing." in cmd:
                continue                  # this process's own forkserver/resource tracker
            found[pid] = cmd
        except OSError:
            continue

    def descends_from_run(pid: int) -> bool:
        for _ in range(64):               # a bounded walk up the parents
            pid = parent.get(pid, 0)
            if pid in ours:
                return True
            if pid <= 1:
                return False
        return False

    return found, {pid for pid in unreadable if descends_from_run(pid)}


#: How long the end of a run waits for its processes' late exits (and for processes still in
#: exec) before it counts those left alive [s]; tests/test_no_process_left.py, whose run leaves
#: a process that never exits, sets it shorter (TENSEGRITY_TEST_LATE_EXITS_S) rather than wait.
LATE_EXITS_S = float(os.environ.get("TENSEGRITY_TEST_LATE_EXITS_S", "10"))


@pytest.hookimpl(trylast=True)     # after pytest-xdist has shut its workers down
def pytest_sessionfinish(session, exitstatus):
    """Fail the run if a process it started is still alive (after :data:`LATE_EXITS_S` for
    late exits and for processes still in exec). With parallel workers the check runs once,
    in the controlling process after every worker has finished (a worker would see the
    others' running nodes)."""
    if hasattr(session.config, "workerinput"):
        return
    deadline = time.monotonic() + LATE_EXITS_S
    while any(scan := _processes_of_this_run()) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = scan[0]
    if not left:
        return
    for pid in left:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    lines = "\n".join(f"  {pid}: {cmd}" for pid, cmd in sorted(left.items()))
    print(f"\nerror: {len(left)} process(es) started by this test run were still alive at its "
          f"end (now killed):\n{lines}")
    session.exitstatus = pytest.ExitCode.TESTS_FAILED

