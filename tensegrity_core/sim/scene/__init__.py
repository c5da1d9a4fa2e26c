"""Scenes: what to simulate, read from YAML (or a dict) and checked before anything runs.

The format is documented in ``docs/scenes.md``. :mod:`.spec` describes a checked scene (the
frozen :class:`Scene` and its parts), :mod:`.reader` reads one from text, a file, parsed data
or a shipped scene's name and checks it with :mod:`.schema` (a robot model's parts:
:mod:`.robot_schema`), :mod:`.series` reads the CSV file of a series input law,
:mod:`.references` knows where a scene names other files. The
names below are the package's public ones.
"""

from tensegrity_core.sim.scene.reader import (
    SCENES_DIR,
    SceneSource,
    load_scene,
    scene_from_dict,
    scene_from_file,
    scene_from_text,
    scene_names,
    scene_path,
)
from tensegrity_core.sim.scene.spec import (
    EFFECTS,
    MAX_OUTPUT_BYTES,
    METHODS,
    NEEDS_INERTIA,
    NOISY_QUANTITIES,
    ROBOT_EFFECTS,
    ActuatorComplianceSpec,
    ActuatorLagSpec,
    Class2ModelSpec,
    ContactSpec,
    DampingSpec,
    EffectSpec,
    FlagSpec,
    FoldLimitSpec,
    FrictionSpec,
    GeneralModelSpec,
    GravitySpec,
    InitialSpec,
    IntegratorSpec,
    LoadsSpec,
    ModelSpec,
    MotorsSpec,
    RobotModelSpec,
    Scene,
    SceneEffects,
    SensorNoiseSpec,
    output_size_reason,
    values_per_sample,
)

__all__ = [
    "EFFECTS", "MAX_OUTPUT_BYTES", "METHODS", "NEEDS_INERTIA", "NOISY_QUANTITIES", "ROBOT_EFFECTS", "SCENES_DIR",
    "ActuatorComplianceSpec", "ActuatorLagSpec", "Class2ModelSpec", "ContactSpec", "DampingSpec", "EffectSpec",
    "FlagSpec", "FoldLimitSpec", "FrictionSpec", "GeneralModelSpec", "GravitySpec", "InitialSpec", "IntegratorSpec",
    "LoadsSpec", "ModelSpec", "MotorsSpec", "RobotModelSpec", "Scene", "SceneEffects", "SceneSource", "SensorNoiseSpec", "load_scene", "output_size_reason",
    "scene_from_dict", "scene_from_file", "scene_from_text", "scene_names", "scene_path", "values_per_sample",
]
