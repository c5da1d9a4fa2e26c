"""MJCF export: the entry point and the writers' registry.

:func:`export_mjcf` takes a scene (or a structure, as :func:`structure_scene`) and hands it
to the MJCF writer of the back end that simulates it; a robot description goes to
:func:`tensegrity_core.export.robot_mjcf.write_robot_mjcf`. A writer belongs to its back end's
package (it writes that back end's physics for MuJoCo), so, like the back ends themselves
(:data:`~tensegrity_core.sim.backends.BACKENDS`), :data:`MJCF_WRITERS` names each as
``module:function`` and imports it on first use:

=====================  ===========================================================
``general/dynamic``    :func:`tensegrity_core.sim.general.mjcf.write_mjcf`
``robot/dynamic``      :func:`tensegrity_core.export.robot_mjcf.write_robot_scene`
=====================  ===========================================================

The class-2 mechanism (a planar linkage with sliding actuators, not a set of bodies and
tendons) and quasi-static scenes (no inertia: MuJoCo simulates dynamics) have none.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from importlib import import_module

import numpy as np

from tensegrity_core.export.errors import ExportError
from tensegrity_core.export.model import MjcfModel
from tensegrity_core.export.robot_mjcf import write_robot_mjcf
from tensegrity_core.general.structure import Structure
from tensegrity_core.robot.description import Robot
from tensegrity_core.sim.backends import backend_name
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.inputs import Commanded
from tensegrity_core.sim.scene import (
    FlagSpec,
    GeneralModelSpec,
    GravitySpec,
    InitialSpec,
    LoadsSpec,
    Scene,
    SceneEffects,
)

#: MuJoCo's integrators (``<option integrator>``); RK4 is the default of scenes and structures
#: (a robot scene's: the robot back end's own fixed-step RK4), implicitfast of robot
#: descriptions (MuJoCo's choice for models with contacts).
INTEGRATORS = ("RK4", "Euler", "implicit", "implicitfast")
#: The MJCF writer of each back end (:func:`~tensegrity_core.sim.backends.backend_name`), as
#: ``module:function`` with the signature ``(scene, timestep or None, integrator) -> MjcfModel``.
MJCF_WRITERS: dict[str, str] = {
    "general/dynamic": "tensegrity_core.sim.general.mjcf:write_mjcf",
    "robot/dynamic": "tensegrity_core.export.robot_mjcf:write_robot_scene",
}
Writer = Callable[[Scene, "float | None", str], "MjcfModel"]


def structure_scene(structure: Structure, *, source: str = "") -> Scene:
    """The scene a structure is exported as: ``inertia`` and ``springs``, its own gravity and
    loads when it has any, no damping, starting from the drawing at rest; actuator members
    hold their drawn rest lengths. (Write a scene for anything else.)"""
    effects: SceneEffects = {"inertia": FlagSpec(), "springs": FlagSpec()}
    if np.any(structure.gravity != 0):
        effects["gravity"] = GravitySpec(tuple(float(g) for g in structure.gravity))
    if np.any(structure.loads != 0):
        effects["loads"] = LoadsSpec({})                    # the structure's own loads only
    actuators = tuple(i for i, k in enumerate(structure.member_kinds) if k == "actuator")
    return Scene(name=structure.name or "structure",
                 model=GeneralModelSpec(structure, source, structure.n_nodes - 1, actuators),
                 initial=InitialSpec("drawn"), inputs={structure.member_names[i]: Commanded(None) for i in actuators},
                 effects=effects, duration=1.0, description=f"the structure {structure.name!r} as drawn")


def export_mjcf(source: Scene | Structure | Robot, *, timestep: float | None = None,
                integrator: str | None = None) -> MjcfModel:
    """The MuJoCo model of a general scene with inertia, of a structure (as
    :func:`structure_scene`) or of a robot (:mod:`tensegrity_core.export.robot_mjcf`).
    ``timestep`` [s] (default: from the fastest rate, see :mod:`tensegrity_core.export.timestep`;
    a robot's: 1 ms; a robot scene's: its own fixed step, ``integrator.max_step``);
    ``integrator`` one of :data:`INTEGRATORS` (default: RK4, as the project integrates a
    scene; a robot description's: implicitfast).

    Raises :class:`ExportError` for a class-2 or quasi-static scene, a bad option, or a
    structure that cannot move (a free node without mass);
    :class:`~tensegrity_core.sim.errors.SceneError` when a scene cannot be simulated (no
    springs, a free node without mass); ``SimulationError`` when its initial equilibrium
    cannot be found."""
    if integrator is None:
        integrator = "implicitfast" if isinstance(source, Robot) else "RK4"
    if integrator not in INTEGRATORS:
        raise ExportError(f"integrator must be one of {', '.join(INTEGRATORS)}, got {integrator!r}")
    if timestep is not None and not (math.isfinite(timestep) and timestep > 0):
        raise ExportError(f"timestep must be a positive number of seconds, got {timestep!r}")
    if isinstance(source, Robot):
        return write_robot_mjcf(source, timestep, integrator)
    scene = source if isinstance(source, Scene) else structure_scene(source)
    if scene.model.kind == "class2":
        raise ExportError(f"scene {scene.name!r} simulates the class-2 mechanism; only general structures "
                          f"export to MJCF")
    if scene.quasi_static:
        raise ExportError(f"scene {scene.name!r} is quasi-static (no 'inertia' in its effects); MuJoCo simulates "
                          f"dynamics: add 'inertia' to export it")
    try:
        return mjcf_writer(backend_name(scene))(scene, timestep, integrator)
    except SceneError as err:
        if isinstance(source, Scene):
            raise
        raise ExportError(f"structure {scene.name!r}: {err.reason}") from None


def mjcf_writer(name: str) -> Writer:
    """The MJCF writer of the back end ``name`` (imported on first use)."""
    module, _, function = MJCF_WRITERS[name].partition(":")
    writer: Writer = getattr(import_module(module), function)
    return writer
