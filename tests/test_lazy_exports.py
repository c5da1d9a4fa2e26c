"""Packages that re-export their modules' names import each module on first use
(tensegrity_core/lazy_exports.py): every name they list resolves to its module's object, and
a process that needs one part does not import the rest (the IK node reads a scene: it must not
load the simulator's back ends, scipy.integrate nor scipy.optimize). ~1 s of CPU in all (one
interpreter start)."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tensegrity_core.lazy_exports import type_checking_imports

LAZY_PACKAGES = ("tensegrity_core.sim", "tensegrity_core.general")


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_every_listed_name_resolves_to_its_modules_object(package):
    module = importlib.import_module(package)
    homes = type_checking_imports(Path(module.__file__).read_text(encoding="utf-8"))
    assert sorted(homes) == sorted(module.__all__)
    for name, (home, original) in homes.items():
        assert getattr(module, name) is getattr(importlib.import_module(home), original), name
    with pytest.raises(AttributeError, match="has no attribute 'no_such_name'"):
        module.no_such_name  # noqa: B018


def test_the_ik_node_imports_neither_the_back_ends_nor_scipy_integrate():
    code = ("import sys, tensegrity_ros.nodes.ik\n"
            "print(' '.join(m for m in ('tensegrity_core.sim.backends', 'tensegrity_core.sim.simulator', "
            "'tensegrity_core.general.formfind', 'scipy.integrate', 'scipy.optimize') if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ))
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split() == []
