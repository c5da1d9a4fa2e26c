"""Scene-driven simulation of tensegrity mechanisms (no ROS import here).

::

    from tensegrity_core.sim import load_scene, Simulator, simulate, SceneError
    scene = load_scene("paper_fold")     # shipped name, path, YAML text or dict (local use)
    scene = scene_from_text(text)        # text from elsewhere: never read as a file name
    sim = Simulator(scene)               # builds only the effects the scene lists
    sim.set_command([f1, f2]); sim.advance(t); obs = sim.observe()
    traj = simulate(scene)               # whole run -> Trajectory (.to_npz, .to_csv)

    model = compile_scene(scene)         # the frozen Model (tensegrity_core.sim.model)
    state = model.initial_state()        # a State: t, y, mode, commands, events; .copy()
    model.set_command(state, [f1, f2]); model.advance(state, t)

See ``docs/scenes.md`` for the scene format, the models and the benchmarks.
"""

from typing import TYPE_CHECKING

from tensegrity_core.lazy_exports import lazy_exports

if TYPE_CHECKING:   # the names and their modules; each imported on first use (lazy_exports)
    from tensegrity_core.sim.backends import BACKENDS, compile_scene
    from tensegrity_core.sim.errors import SceneError, SimulationError
    from tensegrity_core.sim.model import DynamicModel, Model, Names, State
    from tensegrity_core.sim.scene import (
        EFFECTS,
        Scene,
        load_scene,
        scene_from_dict,
        scene_from_file,
        scene_from_text,
        scene_names,
        scene_path,
    )
    from tensegrity_core.sim.simulator import JointSample, Observation, Simulator, simulate
    from tensegrity_core.sim.trajectory import Trajectory

__all__ = ["BACKENDS", "EFFECTS", "DynamicModel", "JointSample", "Model", "Names", "Observation", "Scene",
           "SceneError", "SimulationError", "Simulator", "State", "Trajectory", "compile_scene", "load_scene",
           "scene_from_dict", "scene_from_file", "scene_from_text", "scene_names", "scene_path", "simulate"]

__getattr__ = lazy_exports(__name__)
