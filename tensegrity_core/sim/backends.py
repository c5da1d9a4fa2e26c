"""The registry of simulator back ends: one per model kind and regime, all implementing
:class:`~tensegrity_core.sim.model.Model`.

================================  ================================================================
``class2/dynamic``                class-2 mechanism with inertia (:mod:`.class2.dynamic`)
``class2/quasi-static``           class-2 mechanism, equilibrium path (:mod:`.class2.quasistatic`)
``general/dynamic``               general structure with inertia (:mod:`.general.dynamic`)
``general/quasi-static``          general structure, incremental form-finding (:mod:`.general.quasistatic`)
``robot/dynamic``                 tensegrity robot, fixed-step dynamics (:mod:`.general.robot.dynamic`)
================================  ================================================================

:func:`compile_scene` picks the back end a checked scene asks for (its model kind, and
``inertia`` listed or not) and compiles it. The registry names each back end as
``module:class`` and imports it on first use: the general back ends pull in the
form-finding (scipy.sparse and friends, about half a second of imports) that a class-2 run
never needs.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from tensegrity_core.sim.model import Model
from tensegrity_core.sim.scene import Scene

BACKENDS: dict[str, str] = {
    "class2/dynamic": "tensegrity_core.sim.class2.dynamic:Class2Dynamic",
    "class2/quasi-static": "tensegrity_core.sim.class2.quasistatic:Class2QuasiStatic",
    "general/dynamic": "tensegrity_core.sim.general.dynamic:GeneralDynamic",
    "general/quasi-static": "tensegrity_core.sim.general.quasistatic:GeneralQuasiStatic",
    "robot/dynamic": "tensegrity_core.sim.general.robot.dynamic:RobotDynamic",
}


def backend_name(scene: Scene) -> str:
    """The registry key of the back end for ``scene``: ``"<kind>/<regime>"``."""
    return f"{scene.model.kind}/{'quasi-static' if scene.quasi_static else 'dynamic'}"


def backend(name: str) -> type[Model[Any, Any]]:
    """The back end class registered as ``name`` (imported on first use)."""
    module, _, cls_name = BACKENDS[name].partition(":")
    cls: type[Model[Any, Any]] = getattr(import_module(module), cls_name)
    return cls


def compile_scene(scene: Scene) -> Model[Any, Any]:
    """The frozen :class:`~tensegrity_core.sim.model.Model` of a checked scene (see
    :func:`~tensegrity_core.sim.scene.load_scene`): only the effects it lists are built."""
    if not isinstance(scene, Scene):
        raise TypeError(f"compile_scene takes a checked Scene (load_scene gives one), got {type(scene).__name__}")
    return backend(backend_name(scene))(scene)
