"""The compiled kernels copy arrays with loops, never by slice assignment (kernels/loops.py,
``copy_vector``): numba compiles a slice assignment of an array with its shape-mismatch message
(f-strings of the shapes, ``str.join``) and links that code into every kernel calling one, which
it then optimises and emits again: ~7 s of the set-up's CPU once and ~1 s per such kernel
(docs/design/performance.md, the set-up's numba warm-up).

Read from the kernels' sources (their syntax trees): an assignment to a slice (``out[:] = ...``,
``X[:, :] = ...``) may only store a number: a numeric literal or a numeric constant of the kernel
modules (``BY_SIGN``). A row copied by index (``K[0] = f``) is not seen here.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
KERNEL_MODULES = ("tensegrity_core/sim/general/kernels/loops.py", "tensegrity_core/sim/general/robot/loops.py",
                  "tensegrity_core/sim/general/robot/step_loops.py")


def _numeric_constants(tree: ast.Module) -> set[str]:
    """Module-level names bound to numbers (``BY_SIGN, OFF, ON = -1.0, 0.0, 1.0``)."""
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.Assign):
            for target in node.targets:
                elts = target.elts if isinstance(target, ast.Tuple) else [target]
                values = node.value.elts if isinstance(node.value, ast.Tuple) else [node.value]
                for name, value in zip(elts, values):
                    if isinstance(name, ast.Name) and _is_number(value, set()):
                        names.add(name.id)
    return names


def _is_number(value: ast.expr, constants: set[str]) -> bool:
    if isinstance(value, ast.UnaryOp):
        return _is_number(value.operand, constants)
    if isinstance(value, ast.Constant):
        return isinstance(value.value, (int, float)) and not isinstance(value.value, bool)
    return isinstance(value, ast.Name) and value.id in constants


def _has_slice(index: ast.expr) -> bool:
    return isinstance(index, ast.Slice) or (isinstance(index, ast.Tuple) and any(isinstance(e, ast.Slice)
                                                                                 for e in index.elts))


def slice_copies(source: str, constants: frozenset[str] = frozenset()) -> list[str]:
    """The lines of ``source``'s jit-decorated functions that assign anything but a number (or
    one of ``constants``, names of numbers) to a slice."""
    tree = ast.parse(source)
    constants = constants | _numeric_constants(tree)
    found = []
    for fn in tree.body:
        if not (isinstance(fn, ast.FunctionDef) and any(isinstance(d, ast.Name) and d.id == "jit"
                                                         for d in fn.decorator_list)):
            continue
        for node in ast.walk(fn):
            if isinstance(node, ast.Assign) and not _is_number(node.value, constants):
                for target in node.targets:
                    if isinstance(target, ast.Subscript) and _has_slice(target.slice):
                        found.append(f"{fn.name}: {ast.unparse(node)}")
    return found


@pytest.mark.parametrize("module", KERNEL_MODULES)
def test_the_kernels_copy_arrays_with_loops(module):
    shared = frozenset().union(*(_numeric_constants(ast.parse((ROOT / m).read_text())) for m in KERNEL_MODULES))
    assert slice_copies((ROOT / module).read_text(), shared) == []


def test_the_check_sees_a_slice_copy_and_lets_numbers_through():
    source = ("BY_SIGN = -1.0\n@jit\ndef f(a, b, s):\n    a[:] = b\n    a[1:, :] = b[0]\n    s[:] = BY_SIGN\n"
              "    a[:, 0] = -2.0\n    a[0] = b[0]\n")
    assert slice_copies(source) == ["f: a[:] = b", "f: a[1:, :] = b[0]"]
