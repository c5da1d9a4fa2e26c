"""``tensegrity_sim``: the simulated mechanism (see :mod:`tensegrity_ros.nodes.sim.node`)."""

from tensegrity_ros.nodes.sim.node import SimNode, main

__all__ = ["SimNode", "main"]
