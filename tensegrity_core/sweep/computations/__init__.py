"""What a sweep computes at each point, and the scalar results it can keep.

:data:`COMPUTATIONS` maps each computation's name to it: an object that implements
:class:`~tensegrity_core.sweep.computations.computation.Computation` (``load`` a point's
document, ``run`` it, ``probe`` the base, the ``results`` it offers).

A :class:`ResultDef` says which columns a result gives (``columns``) and how to read them
from an outcome (``extract``); ``prepare`` computes its fixed data once (e.g. a reference
run). Columns have a dtype: ``float`` (missing = NaN), ``int``, ``bool``, ``str``.
"""

from typing import Any

from tensegrity_core.sweep.computations.computation import Computation
from tensegrity_core.sweep.computations.ik import IK
from tensegrity_core.sweep.computations.results import ResultDef, ResultSpec, scalar
from tensegrity_core.sweep.computations.simulate import SIMULATE
from tensegrity_core.sweep.computations.statics import FORM_FIND, STIFFNESS

#: name -> computation
COMPUTATIONS: dict[str, Computation[Any, Any]] = {c.name: c for c in (SIMULATE, FORM_FIND, STIFFNESS, IK)}

__all__ = ["COMPUTATIONS", "Computation", "ResultDef", "ResultSpec", "scalar"]
