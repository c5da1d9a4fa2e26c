"""The names a package re-exports, imported from their modules on first use (PEP 562).

A package ``__init__`` that imports every module whose names it offers makes importing any
one of its modules import them all, with their libraries: the scene reader
(``tensegrity_core.sim.scene``, all the IK node needs of the simulator package) pulled in
the back ends, scipy.integrate and scipy.optimize, and the structure class
(``tensegrity_core.general.structure``) the form-finding and stiffness modules: ~0.5 s of
CPU at every start of the IK node. Such a package writes its names once, as imports under
``if TYPE_CHECKING:`` (what mypy, ruff and tests/test_layers.py read), lists them in
``__all__`` and sets ``__getattr__ = lazy_exports(__name__)``: the first use of a name
(``from tensegrity_core.sim import Simulator``, ``tensegrity_core.sim.Simulator``) imports
its module then. The names and their modules are read from those imports in the package's
own source, so that they are written in one place; a name that is not among them but is a
submodule of the package is imported as one (``tensegrity_core.sim.scene``).

Why not scientific-python's ``lazy_loader``: its ``attach_stub`` reads the names from a
``.pyi`` stub beside the package, which type checkers then read instead of the package's
source (two files to keep in step, and a stub that hides the source from mypy); its
``attach`` takes them as a dict that mypy and ruff cannot see. Reading the package's own
``TYPE_CHECKING`` imports keeps one place for the names that every tool reads.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any


def lazy_exports(package: str) -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package`` (its dotted name) that imports each name
    re-exported under its ``if TYPE_CHECKING:`` from its module on first use, and keeps it."""
    homes: dict[str, tuple[str, str]] = {}

    def __getattr__(name: str) -> Any:
        module = sys.modules[package]
        if not homes and module.__file__:
            homes.update(type_checking_imports(Path(module.__file__).read_text(encoding="utf-8")))
        if name in homes:
            home, original = homes[name]
            value = getattr(importlib.import_module(home), original)
        elif not name.startswith("__") and importlib.util.find_spec(f"{package}.{name}") is not None:
            value = importlib.import_module(f"{package}.{name}")
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        setattr(module, name, value)
        return value

    return __getattr__


def type_checking_imports(source: str) -> dict[str, tuple[str, str]]:
    """``{name: (module, name in it)}`` of the ``from module import ...`` statements under the
    module-level ``if TYPE_CHECKING:`` of ``source``."""
    homes: dict[str, tuple[str, str]] = {}
    for node in ast.parse(source).body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for stmt in node.body:
                if isinstance(stmt, ast.ImportFrom) and stmt.module and not stmt.level:
                    homes.update({alias.asname or alias.name: (stmt.module, alias.name) for alias in stmt.names})
    return homes
