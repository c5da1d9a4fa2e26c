"""What every computation of a sweep implements (:class:`Computation`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, TypeVar

from tensegrity_core.sweep.checks import Check
from tensegrity_core.sweep.computations.results import Options, ResultDef, ResultSpec

#: What a computation's loader gives (a scene, a structure, the mechanism's parameters).
Loaded = TypeVar("Loaded")
#: The outcome of a run, which the results read.
Out = TypeVar("Out")


class Computation(Protocol[Loaded, Out]):
    """A computation of a sweep, ``Computation[Loaded, Out]``: loaded inputs of type ``Loaded``,
    outcomes of type ``Out``. Every computation subclasses it so that the type checker holds it
    to it.

    - ``name``, ``base`` (``"scene"`` or ``"structure"``: the base it needs), ``model``
      (``"class2"`` when only class-2 scenes will do, else ``None``), ``options`` (option name
      -> check), ``required_options``, ``results`` (result name -> :class:`ResultDef`),
      ``required`` (result name -> its required options) and ``uses_seed`` (each point's seed
      goes into the scene), ``modules`` (the core modules its points run on: imported by a
      worker before it times its first point, so that a point's ``run_time`` is its own);
    - ``load(document)``: the core's loader on the point's document; its errors
      (``SceneError``, ``StructureError``) make the point *invalid*;
    - ``run(loaded, options) -> (ok, message, outcome)``: the computation; ``ok`` False makes the
      point *failed* (no equilibrium, a run stopped early) with its results still extracted
      from ``outcome`` where they exist;
    - ``probe(document, options, full=...)``: run once on the machine that reads the sweep
      file, for what result columns and references need (names, sizes, the base's own result);
    - ``finish_options(options, results)``: the options a run gets, given the results kept;
    - ``violations(outcome)``: the invariants of the physics an outcome breaks, one line each
      (a non-empty list makes the point *violated*; by default none are checked).
    """

    name: str
    base: str
    model: str | None
    options: dict[str, Check]
    required_options: tuple[str, ...]
    results: dict[str, ResultDef[Out]]
    required: dict[str, tuple[str, ...]]
    uses_seed: bool
    modules: tuple[str, ...]

    def load(self, document: dict[str, Any]) -> Loaded: ...

    def run(self, loaded: Loaded, options: Options) -> tuple[bool, str, Out]: ...

    def probe(self, document: dict[str, Any], options: Options, *, full: bool) -> Out: ...

    def finish_options(self, options: Options, results: Sequence[ResultSpec]) -> Options: ...

    def violations(self, outcome: Out) -> list[str]:
        return []
