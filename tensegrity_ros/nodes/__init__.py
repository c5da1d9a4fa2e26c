"""The suite's rclpy nodes: ``tensegrity_sim``, ``tensegrity_ik``, ``tensegrity_formfind``.

Each node is an importable class wired in ``__init__``; each module has ``main(argv)``
for ``tensegrity node <name>``. Node files translate messages and delegate to
:mod:`tensegrity_core`; they hold no numerics of their own.
"""
