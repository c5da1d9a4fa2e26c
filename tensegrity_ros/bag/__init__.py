"""Record runs to rosbag2-compatible MCAP bags and replay them (no rosbag2 needed).

One job per module:

- :mod:`.untrusted` what a bag says about itself: its YAML (bounded, safe) and its file names (inside its folder)
- :mod:`.msgdefs`   full ``ros2msg`` definitions (with dependencies) from the installed .msg files
- :mod:`.qos`       rosbag2's YAML form of QoS profiles; QoS to request and to offer
- :mod:`.metadata`  ``metadata.yaml`` (rosbag2 format version 9, as rosbag2 Jazzy writes it)
- :mod:`.writer`    :class:`BagWriter`, a bag folder written with the ``mcap`` library
- :mod:`.reader`    :class:`BagReader`, reads bag folders, also damaged ones (recovery scan)
- :mod:`.repair`    rewrite a damaged bag into a valid one and regenerate its metadata
- :mod:`.info`      the ``bag info`` summary
- :mod:`.plot`      joint positions and end effector against time (decoded without ROS)
- :mod:`.schedule`  replay timing: when each message and each ``/clock`` tick is due
- :mod:`.recorder`  the recording node (rclpy, raw subscriptions)
- :mod:`.player`    the playback node (rclpy, publishes the recorded bytes)

Only :mod:`.recorder` and :mod:`.player` import rclpy; the rest works without ROS.
"""
