"""The points of a sweep: varied quantities, their values, each point's seed and document.

A quantity is a key path into the base document with either fixed values (``values`` or a
``grid``) or a distribution (``uniform``, ``normal``, ``log_uniform``). Points are the
Cartesian product of the fixed quantities' values (the first listed varies slowest), each
repeated ``samples`` times when the sweep has random quantities. Point ``i`` is defined by
the sweep's ``seed`` and ``i`` alone: its random values come from a generator seeded with
``SeedSequence(seed, spawn_key=(i, 0))`` and its own seed (given to the scene, for sensor
noise) from ``spawn_key=(i, 1)``. So a point's inputs and result never depend on which
worker ran it or in which order, and more samples extend a Monte Carlo run without changing
the first ones. With ``scale: true`` a value multiplies the base document's value at the
key path (a factor), at every location the key path selects.
"""

from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tensegrity_core.schema.errors import KeyPath
from tensegrity_core.schema.keypath import get_at, set_in_place

FIXED = ("values", "grid")
RANDOM = ("uniform", "normal", "log_uniform")


@dataclass(frozen=True)
class Quantity:
    """One varied quantity. ``values`` for fixed kinds; ``params`` (low, high) for
    ``uniform`` / ``log_uniform``, (mean, std) for ``normal``; ``locations`` where the key
    path lands in the base document."""

    path: str
    column: str
    kind: str
    values: tuple[Any, ...] = ()
    params: tuple[float, ...] = ()
    scale: bool = False
    locations: tuple[KeyPath, ...] = ()
    log: bool = False          # a log-spaced grid or a log-uniform distribution (plots)

    @property
    def random(self) -> bool:
        return self.kind in RANDOM

    def draw(self, rng: np.random.Generator) -> float:
        a, b = self.params
        if self.kind == "uniform":
            return float(rng.uniform(a, b))
        if self.kind == "normal":
            return float(rng.normal(a, b))
        return float(math.exp(rng.uniform(math.log(a), math.log(b))))


@dataclass(frozen=True)
class Point:
    """Point ``index`` of the sweep: one value per quantity (in the sweep's order) and the
    point's own seed (a non-negative integer)."""

    index: int
    values: tuple[Any, ...]
    seed: int


def grid_values(start: float, stop: float, num: int, spacing: str = "linear") -> tuple[float, ...]:
    """``num`` values from ``start`` to ``stop`` (both included), linear or logarithmic."""
    if spacing == "log":
        return tuple(float(v) for v in np.geomspace(start, stop, num))
    return tuple(float(v) for v in np.linspace(start, stop, num))


def point_seed(seed: int, index: int) -> int:
    """The seed of point ``index`` (for the scene's sensor noise)."""
    return int(np.random.SeedSequence(seed, spawn_key=(index, 1)).generate_state(1)[0])


def count(quantities: Sequence[Quantity], samples: int) -> int:
    fixed = [len(q.values) for q in quantities if not q.random]
    n = math.prod(fixed) if fixed else 1
    return n * (samples if any(q.random for q in quantities) else 1)


def build_points(quantities: Sequence[Quantity], samples: int, seed: int) -> list[Point]:
    """Every point of the sweep, in index order."""
    fixed = [q for q in quantities if not q.random]
    random = any(q.random for q in quantities)
    repeats = samples if random else 1
    combos = list(itertools.product(*(q.values for q in fixed)))
    points = []
    for c, combo in enumerate(combos):
        for r in range(repeats):
            index = c * repeats + r
            values: tuple[Any, ...] = combo          # every quantity fixed
            if random:
                rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index, 0)))
                it = iter(combo)
                values = tuple(q.draw(rng) if q.random else next(it) for q in quantities)
            points.append(Point(index, values, point_seed(seed, index)))
    return points


def apply(document: dict[str, Any], quantities: Sequence[Quantity], values: Sequence[Any]) -> dict[str, Any]:
    """A copy of ``document`` with the point's ``values`` written at every location."""
    out = copy.deepcopy(document)
    for q, value in zip(quantities, values):
        for loc in q.locations:
            set_in_place(out, loc, get_at(document, loc) * value if q.scale else value)
    return out
