"""The rules that keep the layers apart (docs/architecture.md), checked on the sources.

Every ``import`` statement of the product code is read with :mod:`ast`, wherever it stands
(module level, inside a function or under ``if TYPE_CHECKING:``), so lazy and type-only
imports count too. A ``from package import name`` is an import of the submodule
``package.name`` when there is one, else of ``package``. The implicit import of a module's parent packages is not counted: a package
``__init__`` that re-exports its submodules would otherwise be a cycle with each of them,
although Python runs a package being initialised only once; an explicit import of the
package (``from tensegrity_core.general import ...``) counts. Imports that only
``importlib.import_module`` makes (the back-end registry, the CLI's command discovery) are
invisible here by design; ``tests/test_foundation.py`` imports the core without ROS.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("tensegrity_core", "tensegrity_ros")

#: ROS client libraries, interface (message) packages and the ROS layer: the core imports none.
ROS_PACKAGES = frozenset({
    "rclpy", "rosbag2_py", "builtin_interfaces", "std_msgs", "sensor_msgs", "geometry_msgs",
    "visualization_msgs", "trajectory_msgs", "rosgraph_msgs", "tensegrity_msgs",
    "simulation_interfaces", "action_msgs", "rcl_interfaces", "std_srvs", "tensegrity_ros",
})
ROS_PREFIXES = ("rcl", "rosidl", "rosbag2")
ROS_SUFFIXES = ("_msgs", "_srvs", "_interfaces")

#: The simulator's back ends: reached only through the registry (tensegrity_core.sim.backends).
BACKEND_PACKAGES = ("tensegrity_core.sim.class2", "tensegrity_core.sim.general")


@dataclass(frozen=True)
class Import:
    source: str       # importing module (dotted)
    target: str       # imported module (dotted, absolute)
    where: str        # file:line, for the messages


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


FILES = {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


class _Imports(ast.NodeVisitor):
    def __init__(self, module: str, is_package: bool, where: str) -> None:
        self.module, self.package = module, module if is_package else module.rpartition(".")[0]
        self.where, self.found = where, list[Import]()

    def _add(self, target: str, node: ast.stmt) -> None:
        self.found.append(Import(self.module, target, f"{self.where}:{node.lineno}"))

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            self._add(alias.name, node)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        if node.level:
            parts = self.package.split(".")
            base = ".".join(parts[:len(parts) - node.level + 1] + ([node.module] if node.module else []))
        else:
            base = node.module or ""
        for alias in node.names:
            sub = f"{base}.{alias.name}"
            self._add(sub if sub in FILES else base, node)


def imports_in(source: str, module: str, *, is_package: bool = False, where: str = "<text>") -> list[Import]:
    """Every import in the source of ``module``, those under ``if TYPE_CHECKING:`` included."""
    visitor = _Imports(module, is_package, where)
    visitor.visit(ast.parse(source, where))
    return visitor.found


def imports(module: str) -> list[Import]:
    """Every import of the product module ``module`` (see :func:`imports_in`)."""
    path = FILES[module]
    return imports_in(path.read_text(), module, is_package=path.name == "__init__.py",
                      where=str(path.relative_to(ROOT)))


def _modules(package: str) -> Iterator[str]:
    return (m for m in FILES if m == package or m.startswith(package + "."))


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _is_ros(module: str) -> bool:
    top = module.partition(".")[0]
    return top in ROS_PACKAGES or top.startswith(ROS_PREFIXES) or top.endswith(ROS_SUFFIXES)


def test_the_import_reader_sees_lazy_relative_and_type_only_imports():
    """The checks below are only as good as this reader: it must find what they look for."""
    source = (
        "from typing import TYPE_CHECKING\n"
        "import rclpy.node\n"
        "from . import model\n"
        "from ..general import statics, DofLayout\n"
        "if TYPE_CHECKING:\n"
        "    from tensegrity_core.sim.class2 import plant\n"
        "else:\n"
        "    import math\n"
        "def f():\n"
        "    from tensegrity_core.sim import class2\n"
    )
    every = ["typing", "rclpy.node", "tensegrity_core.sim.model", "tensegrity_core.general.statics",
             "tensegrity_core.general", "tensegrity_core.sim.class2.plant", "math", "tensegrity_core.sim.class2"]
    assert [i.target for i in imports_in(source, "tensegrity_core.sim.x")] == every
    in_package = imports_in("from . import model\nfrom .class2 import plant\n", "tensegrity_core.sim", is_package=True)
    assert [i.target for i in in_package] == ["tensegrity_core.sim.model", "tensegrity_core.sim.class2.plant"]
    assert _is_ros("rclpy.node") and _is_ros("geometry_msgs.msg") and not _is_ros("numpy")


def test_the_core_never_imports_ros():
    bad = [f"{i.where}: {i.target}" for m in _modules("tensegrity_core") for i in imports(m) if _is_ros(i.target)]
    assert not bad, "tensegrity_core must run without ROS:\n" + "\n".join(bad)


def test_the_product_never_imports_the_studies():
    """``studies`` (derivations, verification runs, the docs' figures) sits beside the product:
    nothing in tensegrity_core or tensegrity_ros imports it, not even inside a function."""
    bad = [f"{i.where}: {i.target}" for m in FILES for i in imports(m) if _inside(i.target, "studies")]
    assert not bad, "the product must not depend on studies/:\n" + "\n".join(bad)


def test_back_ends_are_reached_only_through_the_sim_api():
    """Outside a back end's own package nothing imports it (nodes, apps, CLI, sweeps, the
    other back ends): the registry ``tensegrity_core.sim.backends.BACKENDS`` names them."""
    bad = [f"{i.where}: {i.target}" for m in FILES for i in imports(m) for pkg in BACKEND_PACKAGES
           if _inside(i.target, pkg) and not _inside(m, pkg)]
    assert not bad, "use tensegrity_core.sim (compile_scene, Model, State, Simulator) instead:\n" + "\n".join(bad)


def test_the_core_has_no_import_cycle():
    """Every cycle among tensegrity_core's modules, as its strongly connected components
    (scipy.sparse.csgraph): each is listed with the imports that close it. Imports under
    ``if TYPE_CHECKING:`` count: a type-only import is still a dependency of the module's
    meaning, and a circle of them is one a reader has to untangle."""
    names = sorted(_modules("tensegrity_core"))
    index = {name: k for k, name in enumerate(names)}
    edges = [i for m in names for i in imports(m) if i.target in index and i.target != m]
    rows, cols = [index[i.source] for i in edges], [index[i.target] for i in edges]
    graph = coo_array((np.ones(len(edges)), (rows, cols)), shape=(len(names), len(names)))
    _, label = connected_components(graph, directed=True, connection="strong")
    cycles = []
    for component in {int(c) for c in label if np.count_nonzero(label == c) > 1}:
        members = {names[k] for k in np.flatnonzero(label == component)}
        closing = sorted({f"  {i.where}: {i.source} -> {i.target}" for i in edges
                         if i.source in members and i.target in members})
        cycles.append(f"{sorted(members)}:\n" + "\n".join(closing))
    assert not cycles, "import cycles in tensegrity_core:\n" + "\n".join(sorted(cycles))
