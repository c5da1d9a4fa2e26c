"""The order and bounds in which :class:`tensegrity_ros.apps.launch.Launcher` stops its children.

A child that records the others' messages (``tensegrity up --record``'s recorder) must see
their last messages: it is signalled only after every other child has exited (or, failing
that, been killed), then it flushes and closes its bag. Each stage escalates on its own:
SIGINT, wait up to ``grace`` seconds; SIGTERM, wait up to :data:`TERM_S`; SIGKILL, wait up
to :data:`KILL_S`. A stop therefore takes at most :func:`stop_bound_s` seconds, whatever a
child does.

Pure policy: the signalling and the waiting are the caller's (``send(name, sig)``;
``wait(names, timeout_s)`` returns the names still running).
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Collection, Sequence

#: Seconds a stage waits after SIGTERM before SIGKILL.
TERM_S = 2.0
#: Seconds a stage waits after SIGKILL before the next stage starts regardless.
KILL_S = 2.0


def stop_stages(names: Sequence[str], last: Collection[str]) -> list[list[str]]:
    """Children to stop together, in order: every child not in ``last``, then those in ``last``
    (order of ``names`` kept; empty stages dropped)."""
    stages = [[n for n in names if n not in last], [n for n in names if n in last]]
    return [s for s in stages if s]


def escalation(grace: float) -> list[tuple[signal.Signals, float]]:
    """Each stage's signals with the seconds waited after each."""
    return [(signal.SIGINT, grace), (signal.SIGTERM, TERM_S), (signal.SIGKILL, KILL_S)]


def stop_bound_s(n_stages: int, grace: float) -> float:
    """Longest time [s] :func:`stop_in_stages` waits for ``n_stages`` stages."""
    return n_stages * sum(wait for _, wait in escalation(grace))


def stop_in_stages(stages: Sequence[Sequence[str]], grace: float, send: Callable[[str, signal.Signals], None],
                   wait: Callable[[list[str], float], Collection[str]],
                   stage_done: Callable[[list[str], list[str]], None] = lambda stage, running: None) -> None:
    """Stop ``stages`` one after another, escalating within each; ``stage_done(stage, running)``
    is called once a stage's children have all exited or its escalation is spent (``running``:
    those still running then, children that outlasted even SIGKILL's wait)."""
    for stage in stages:
        running = list(stage)
        for sig, wait_s in escalation(grace):
            for name in running:
                send(name, sig)
            still = set(wait(running, wait_s))
            running = [n for n in running if n in still]
            if not running:
                break
        stage_done(list(stage), running)
