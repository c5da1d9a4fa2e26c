"""What a sweep computes at each point, and the scalar results it can keep.

A computation (``COMPUTATIONS[name]``) is an object with:

- ``name``, ``base`` (``"scene"`` or ``"structure"``: the base it needs), ``model`` (``"class2"``
  when only class-2 scenes will do, else ``None``), ``options`` (option name -> check) and
  ``results`` (result name -> :class:`ResultDef`);
- ``load(document)``: the core's loader on the point's document; its errors
  (``SceneError``, ``StructureError``) make the point *invalid*;
- ``run(loaded, options) -> (ok, message, outcome)``: the computation; ``ok`` False makes the
  point *failed* (no equilibrium, a run stopped early) with its results still extracted
  from ``outcome`` where they exist;
- ``probe(document, options)``: run once on the machine that reads the sweep file, for what
  result columns and references need (names, sizes, the base's own result).

A :class:`ResultDef` says which columns a result gives (``columns``) and how to read them
from an outcome (``extract``); ``prepare`` computes its fixed data once (e.g. a reference
run). Columns have a dtype: ``float`` (missing = NaN), ``int``, ``bool``, ``str``.
"""

from tensegrity_core.sweep.computations.ik import IK
from tensegrity_core.sweep.computations.results import ResultDef, ResultSpec, scalar
from tensegrity_core.sweep.computations.simulate import SIMULATE
from tensegrity_core.sweep.computations.statics import FORM_FIND, STIFFNESS

#: name -> computation
COMPUTATIONS = {c.name: c for c in (SIMULATE, FORM_FIND, STIFFNESS, IK)}

__all__ = ["COMPUTATIONS", "ResultDef", "ResultSpec", "scalar"]
