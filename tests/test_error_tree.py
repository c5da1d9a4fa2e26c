"""Errors in one tree: every exception class the product defines derives from
:class:`~tensegrity_core.errors.TensegrityError`, so a caller (the CLI, a node, a user's
script) catches one class and shows its one-line message.

Every module of tensegrity_core and tensegrity_ros is imported and the exception classes
defined at its top level are checked.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

from tensegrity_core.errors import TensegrityError

PACKAGES = ("tensegrity_core", "tensegrity_ros")

#: Exception classes that must not be TensegrityErrors, with why.
OUTSIDE_THE_TREE = {
    # Raised while a node starts, to stop the process with its message and no traceback: it
    # must stay out of every ``except Exception`` on the way (a TensegrityError is one).
    "tensegrity_ros.nodes.common.ParameterValueError",
    # A warning, not an error: issued with warnings.warn so a script can filter or raise it,
    # and a run goes on after it.
    "tensegrity_core.sim.stiffness_check.StiffnessWarning",
}


def _exception_classes() -> dict[str, type[BaseException]]:
    found = {}
    for package in PACKAGES:
        for info in pkgutil.walk_packages(importlib.import_module(package).__path__, package + "."):
            if info.name.rpartition(".")[2] == "__main__":
                continue
            module = importlib.import_module(info.name)
            for name, value in vars(module).items():
                if (inspect.isclass(value) and issubclass(value, BaseException)
                        and value.__module__ == module.__name__):
                    found[f"{module.__name__}.{name}"] = value
    return found


def test_every_exception_the_product_defines_is_a_tensegrity_error():
    classes = _exception_classes()
    assert len(classes) > 20 and "tensegrity_core.sweep.errors.SweepError" in classes   # the walk found them
    bad = sorted(name for name, cls in classes.items()
                 if not issubclass(cls, TensegrityError) and name not in OUTSIDE_THE_TREE)
    assert not bad, "derive these from TensegrityError (or a subclass):\n" + "\n".join(bad)
    stale = sorted(name for name in OUTSIDE_THE_TREE if name not in classes or issubclass(classes[name], TensegrityError))
    assert not stale, f"no longer outside the tree: {stale}"
