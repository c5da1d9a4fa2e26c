"""The ``scene`` parameter of the nodes that model the class-2 mechanism (the simulator, the
IK node and the controller): the mechanism's parameters from one source.

The scene reader (``tensegrity_core.sim.scene``: the scene's checks, not the simulator's back
ends, :mod:`tensegrity_core.lazy_exports`) is imported here, at module level, so
every node that uses it has it loaded before the node starts running: a stop signal that
comes while a process imports ends it at once, one that comes while its node is being built
waits for the build (:mod:`tensegrity_ros.rclpy_utils.stop_signals`). Imported inside
:func:`declare_scene` it would make building the IK node take 0.7 s on an idle machine
(several seconds on a loaded one), and a SIGINT in that time would wait for all of it. The
form-finding node, which needs no scene, does not import this module.
"""

from __future__ import annotations

from rclpy.node import Node

from tensegrity_core.class2 import Class2Params
from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import clip, excerpt
from tensegrity_core.sim import Scene, load_scene
from tensegrity_core.sim.scene.spec import Class2ModelSpec
from tensegrity_ros.nodes.common import ParameterValueError, declare

#: The scene every node that models the class-2 mechanism reads it from (one source).
DEFAULT_SCENE = "class2_at_rest"


def declare_scene(node: Node, *, class2_only: bool = True) -> tuple[str, Scene]:
    """Declare the read-only ``scene`` parameter and load it: ``(name, Scene)``.

    The simulator, the IK node and the controller all take the mechanism (L, k1..k4, masses,
    dampers) from this one parameter, so none can disagree with the simulated mechanism.
    A scene that cannot be loaded, or (``class2_only``: the IK node and the controller) is
    not of the class-2 mechanism, stops the node with a message naming it.
    """
    name = declare(node, "scene", DEFAULT_SCENE,
                   "scene file or shipped scene name (tensegrity scenes lists them); the mechanism's "
                   "parameters come from it", read_only=True)
    try:
        scene = load_scene(name)
    except TensegrityError as err:
        raise ParameterValueError(clip(f"{node.get_name()}: cannot load scene {excerpt(name)}: {err}")) from None
    if class2_only and scene.model.kind != "class2":
        raise ParameterValueError(f"{node.get_name()}: scene {excerpt(name)} models a general structure; this node works "
                         "on the class-2 mechanism")
    return name, scene


def scene_mechanism(node: Node) -> Class2Params:
    """The class-2 parameters of the node's ``scene`` parameter (declared here)."""
    model = declare_scene(node)[1].model
    assert isinstance(model, Class2ModelSpec)           # declare_scene refused any other
    return model.params
