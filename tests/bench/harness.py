"""Minimal benchmark harness.

A benchmark is a function in a module ``tests/bench/bench_<group>.py`` decorated with
``@benchmark``. It receives a :class:`Context` and returns a list of :class:`Row`. Timing
claims are ratios against a baseline measured in the same run (these machines are shared
and noisy), so a row may name its ``baseline`` row; the harness then reports the ratio.
"""

from __future__ import annotations

import gc
import json
import math
import re
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Final

REGISTRY: list[tuple[str, Callable]] = []


@dataclass
class Context:
    quick: bool = True           # CI smoke mode (seconds) vs full mode (docs figures)
    plot_dir: str | None = None  # where plots (PNG) go; None: no plots
    data_dir: str | None = None  # where raw data (JSON) goes; None: not written
    extra: dict = field(default_factory=dict)
    #: what :meth:`kept` entered, closed by :meth:`close` when the run ends
    _kept: dict = field(default_factory=dict)
    _stack: ExitStack = field(default_factory=ExitStack)

    def kept(self, key: str, make: Callable[[], AbstractContextManager]):
        """The value of ``make()`` entered once per run under ``key`` and shared by every
        benchmark that asks for it (a cluster or a node suite several quick benchmarks use:
        started once instead of once each); it is exited when the runner closes the context."""
        if key not in self._kept:
            self._kept[key] = self._stack.enter_context(make())
        return self._kept[key]

    def close(self) -> None:
        """Exit everything :meth:`kept` entered, the last entered first."""
        self._kept.clear()
        self._stack.close()

    def plot_path(self, name: str) -> Path | None:
        """``plot_dir/name`` (folder created), or None when no plots are wanted."""
        if self.plot_dir is None:
            return None
        Path(self.plot_dir).mkdir(parents=True, exist_ok=True)
        return Path(self.plot_dir) / name

    def save_json(self, name: str, data) -> Path | None:
        """Write ``data`` as ``data_dir/name`` (JSON); None when no data dir is set."""
        if self.data_dir is None:
            return None
        Path(self.data_dir).mkdir(parents=True, exist_ok=True)
        path = Path(self.data_dir) / name
        path.write_text(json.dumps(data, indent=1, default=_jsonable))
        return path


def _jsonable(value):
    """numpy scalars and arrays, and non-finite floats, for json.dumps."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


@dataclass
class Row:
    group: str
    name: str
    value: float
    unit: str
    baseline: str | None = None   # name of the row this one is compared with
    target: str = ""              # the claim, e.g. "< 20 us" or ">= 50x"
    note: str = ""
    ratio: float | None = None    # filled in by the harness: :func:`ratio_to_baseline`
    bench: str = ""               # filled in by the harness: the benchmark function's name
    #: whether the target is met: set by a benchmark whose target is words ("on the front"),
    #: else filled in by the harness from the target (:func:`target_met`); None: not checked
    met: bool | None = None


#: Units a target may give in another scale than its row's (factor to the family's base).
UNIT_SCALES: Final = {
    "s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9,
    "m": 1.0, "mm": 1e-3, "um": 1e-6,
    "Hz": 1.0, "kHz": 1e3,
    "B": 1.0, "KiB": 2.0**10, "MiB": 2.0**20, "GiB": 2.0**30,
}
_FAMILY: Final = {**dict.fromkeys(("s", "ms", "us", "µs", "ns"), "time"), **dict.fromkeys(("m", "mm", "um"), "length"),
                  **dict.fromkeys(("Hz", "kHz"), "rate"), **dict.fromkeys(("B", "KiB", "MiB", "GiB"), "memory")}
_TARGET: Final = re.compile(r"\s*(ratio\s+)?(<=|>=|==|<|>)\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?)(x\b)?\s*([A-Za-zµ]*)")
_COMPARE: Final = {"<": float.__lt__, "<=": float.__le__, ">": float.__gt__, ">=": float.__ge__, "==": float.__eq__}


def is_rate(unit: str) -> bool:
    """Whether ``unit`` is a rate (more per second is more): ``Hz``, ``kHz``, ``fps`` or
    ``THING/s`` (``states/s``, ``1/s``); a time per second (``s/s``, a cost) is not one."""
    u = unit.split()[0] if unit.split() else ""
    thing, per, second = u.rpartition("/")
    return u in ("Hz", "kHz", "fps") or (bool(per) and second == "s" and _FAMILY.get(thing) != "time")


def ratio_to_baseline(row: Row, base: Row) -> float | None:
    """How ``row`` compares with its baseline row, in the direction that reads right: a
    rate's value ÷ the baseline's ("0.22x of baseline": 13.5 fps against 60.7 fps), any
    other row's baseline ÷ value (a time's speed-up: "4.50x" is 4.5 times faster). None
    when the divisor is 0."""
    num, den = (row.value, base.value) if is_rate(row.unit) else (base.value, row.value)
    return num / den if den else None


def format_ratio(row: Row) -> str:
    """The table's "vs baseline" entry of ``row`` (its ratio set): ``4.50x``, ``0.22x of baseline``."""
    return f"{row.ratio:.2f}x" + (" of baseline" if is_rate(row.unit) else "")


def target_met(row: Row) -> bool | None:
    """Whether ``row`` meets its target, when the target is a comparison: ``OP NUMBER
    [UNIT]`` against the value (a unit of another scale of the row's unit is converted:
    ``< 2 ms`` for a row in us; a row per call, ``us/call``, is compared per call: ``< 20 us``;
    words after it are a comment), ``OP NUMBERx`` or ``ratio OP NUMBER`` against the ratio
    to the baseline (:func:`ratio_to_baseline`). None for a target in words ("close to 1",
    "on the front") or one that cannot be compared (no ratio, another unit)."""
    m = _TARGET.match(row.target)
    if m is None:
        return None
    ratio_word, op, number, times, unit = m.groups()
    bound = float(number)
    if ratio_word or times:
        return None if row.ratio is None else _COMPARE[op](float(row.ratio), bound)
    mine = row.unit.split()[0] if row.unit.split() else ""
    if "/" not in unit and mine.partition("/")[2] not in ("", "s"):
        mine = mine.partition("/")[0]   # "< 20 us" of a row in us/call: 20 us per call
    if unit in UNIT_SCALES and unit != mine:
        if _FAMILY.get(unit) != _FAMILY.get(mine):
            return None
        bound *= UNIT_SCALES[unit] / UNIT_SCALES[mine]
    if math.isnan(row.value):
        return False
    return _COMPARE[op](float(row.value), bound)


def benchmark(fn: Callable) -> Callable:
    group = fn.__module__.rsplit(".", 1)[-1].removeprefix("bench_")
    REGISTRY.append((group, fn))
    return fn


@contextmanager
def no_gc():
    """The garbage collector off while timing (as ``timeit`` does): a collection that an
    earlier benchmark's garbage triggers would otherwise land on whoever runs next."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


@dataclass(frozen=True)
class Timing:
    """The default length of a measurement: each timing runs for at least ``min_time`` s,
    :func:`time_per_call` takes the best of ``repeat`` such runs."""

    min_time: float
    repeat: int


#: Full mode (the docs' figures), and quick mode (CI's smoke run: it checks that every
#: benchmark runs and reports, over some thirty benchmarks and ~200 timings in all; a timing
#: there is a best of two 20 ms runs, its figures rough).
FULL_TIMING: Final = Timing(min_time=0.2, repeat=5)
QUICK_TIMING: Final = Timing(min_time=0.02, repeat=2)
_timing = FULL_TIMING


def use_timing(timing: Timing) -> Timing:
    """Make ``timing`` the default of :func:`best_run` and :func:`time_per_call` (the runner
    sets it from the mode; arguments given to a call still win); returns the one it replaces."""
    global _timing
    previous, _timing = _timing, timing
    return previous


def best_run(fn: Callable[[], object], repeat: int, min_time: float | None = None, max_time: float = math.inf):
    """``(best wall time, result)`` of ``fn()`` over at least ``repeat`` runs and
    ``min_time`` s (default: the mode's, :func:`use_timing`), a millisecond run getting as
    fair a chance at a quiet moment as a long one; no repeat once ``max_time`` s are spent
    (noise matters little to a run that long)."""
    min_time = _timing.min_time if min_time is None else min_time
    best, out, spent, n = math.inf, None, 0.0, 0
    while (n < repeat or spent < min_time) and not (n and spent > max_time):
        with no_gc():
            t0 = time.perf_counter()
            out = fn()
            dt = time.perf_counter() - t0
        best, spent, n = min(best, dt), spent + dt, n + 1
    return best, out


def time_per_call(fn: Callable[[], object], *, min_time: float | None = None, repeat: int | None = None) -> float:
    """Best-of-``repeat`` seconds per call of ``fn``, each repeat running >= ``min_time``
    (defaults: the mode's, :func:`use_timing`)."""
    with no_gc():
        return _time_per_call(fn, _timing.min_time if min_time is None else min_time,
                              _timing.repeat if repeat is None else repeat)


def _time_per_call(fn, min_time: float, repeat: int) -> float:
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
