"""tensegrity_ros: thin rclpy nodes and command-line tools over :mod:`tensegrity_core`.

Importing this package does not import rclpy; the ROS modules do, when they are used.
"""

__version__ = "0.1.0"
