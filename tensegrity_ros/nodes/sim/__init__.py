"""``tensegrity_sim``: the simulated mechanism (the node: :mod:`tensegrity_ros.nodes.sim.node`).

The package imports none of its modules: importing a part (:mod:`.cable_commands`, say)
does not load the node."""

#: The simulator ``N`` takes its commands through a second node of its process, ``N`` with this
#: suffix, in its namespace (its own executor thread: commands never wait behind stepping).
COMMANDS_NODE_SUFFIX = "_commands"
