"""The suite's rclpy nodes and the helpers they use: ``tensegrity_sim`` (package
:mod:`.sim`: receiver, plant, sender, run control, parameters), ``tensegrity_ik``
(:mod:`.ik`), ``tensegrity_formfind`` (:mod:`.formfind` and its worker process,
:mod:`.formfind_worker`), ``tensegrity_controller`` (:mod:`.controller`); command
parsing (:mod:`.actuator_commands`) and parameter declaration (:mod:`.common`).

Each node is an importable class wired in ``__init__``; each node module has
``main(argv)`` for ``tensegrity node <name>``. Nodes translate messages and delegate to
:mod:`tensegrity_core`; they hold no numerics of their own.
"""
