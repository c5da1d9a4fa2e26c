"""Minimal benchmark harness.

A benchmark is a function in a module ``tests/bench/bench_<group>.py`` decorated with
``@benchmark``. It receives a :class:`Context` and returns a list of :class:`Row`. Timing
claims are ratios against a baseline measured in the same run (these machines are shared
and noisy), so a row may name its ``baseline`` row; the harness then reports the ratio.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

REGISTRY: list[tuple[str, Callable]] = []


@dataclass
class Context:
    quick: bool = True           # CI smoke mode (seconds) vs full mode (docs figures)
    plot_dir: str | None = None  # where full mode writes PNGs
    extra: dict = field(default_factory=dict)


@dataclass
class Row:
    group: str
    name: str
    value: float
    unit: str
    baseline: str | None = None   # name of the row this one is compared with
    target: str = ""              # the claim, e.g. "< 20 us" or ">= 50x"
    note: str = ""
    ratio: float | None = None    # filled in by the harness: baseline.value / value


def benchmark(fn: Callable) -> Callable:
    group = fn.__module__.rsplit(".", 1)[-1].removeprefix("bench_")
    REGISTRY.append((group, fn))
    return fn


def time_per_call(fn: Callable[[], object], *, min_time: float = 0.2, repeat: int = 5) -> float:
    """Best-of-``repeat`` seconds per call of ``fn``, each repeat running >= ``min_time``."""
    n = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        dt = time.perf_counter() - t0
        if dt >= min_time / 4:
            break
        n *= 4
    n = max(1, int(n * (min_time / max(dt, 1e-9))))
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - t0) / n)
    return best
