"""``tensegrity_sim``: the simulated mechanism (the node: :mod:`tensegrity_ros.nodes.sim.node`).

The package imports none of its modules: importing a part (:mod:`.cable_commands`, say)
does not load the node."""
