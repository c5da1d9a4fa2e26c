"""rclpy utilities of the suite, none of them tied to a node: the process environment for
DDS (:mod:`.env`), waiting for matches (:mod:`.matching`) and futures (:mod:`.futures`),
taking raw messages (:mod:`.raw_take`), waiting for subscribers' acknowledgements before a
publisher goes (:mod:`.delivery`), message classes and plain copies (:mod:`.messages`),
signals as stop requests of a node's process (:mod:`.stop_signals`, no rclpy import).
"""
