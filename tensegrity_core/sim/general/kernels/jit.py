"""Which kernels evaluate a general model: compiled loops (numba) or numpy arrays.

``numba`` (an optional dependency, the ``fast`` extra) compiles the explicit-loop kernels of
:mod:`.loops` to machine code, cached on disk next to the sources (``cache=True``: a process
that finds the cache loads the kernels in well under a second instead of compiling them).
Without numba, or when asked (``kernels="numpy"``, or the environment variable
``TENSEGRITY_KERNELS=numpy``), the array kernels of :mod:`.arrays` compute the same numbers
to rounding with numpy alone.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from typing import Any, TypeVar

from tensegrity_core.sim.errors import SimulationError


def _numba() -> Any:
    """The numba module, or None where it is not installed (the numpy kernels work without it)."""
    try:
        return importlib.import_module("numba")
    except ImportError:
        return None


numba: Any = _numba()

#: The kernel families, fastest first.
KERNELS = ("numba", "numpy")
#: Environment variable that picks the kernels when a model does not say.
KERNELS_VARIABLE = "TENSEGRITY_KERNELS"

F = TypeVar("F", bound=Callable[..., Any])


def have_numba() -> bool:
    return numba is not None


def jit(fn: F) -> F:
    """``fn`` compiled by numba (nopython, cached on disk, no GIL), or ``fn`` itself without numba."""
    if numba is None:
        return fn
    compiled: F = numba.njit(cache=True, nogil=True)(fn)
    return compiled


def choose_kernels(kernels: str | None = None) -> str:
    """``"numba"`` or ``"numpy"``: ``kernels`` if given, else the environment's choice
    (:data:`KERNELS_VARIABLE`), else numba where it is installed."""
    choice = kernels if kernels is not None else os.environ.get(KERNELS_VARIABLE, "") or None
    if choice is None:
        return "numba" if have_numba() else "numpy"
    if choice not in KERNELS:
        raise SimulationError(f"unknown kernels {choice!r}; use one of {', '.join(KERNELS)}")
    if choice == "numba" and not have_numba():
        raise SimulationError("the numba kernels need numba (pip install 'tensegrity-ros[fast]'); "
                              "the numpy kernels compute the same without it")
    return choice
