"""The simulator's ``/tf``: the frame of each moving rigid body (a robot's rods and bodies)
in the world frame, as tf2 listeners, RViz and robot_localization read it. A pure function
from an observation to a message, like :mod:`.sender`.

Each transform goes from the world frame (parent: the ``frame_id`` of body_states, the
simulator's ``frame_id`` parameter) to a body's frame (child: the body's name after the
simulator's ``frame_prefix``, the ``frame_id`` of its IMU's ``imu/<body>``). It is the body's pose of body_states: translation
= the body's centre [m] in the world frame, rotation = the quaternion that takes vectors
from the body's frame to the world frame (the body's frame has the world's axes in the
drawing, so it maps a rod's drawn axis onto the line of its two caps now).
"""

from __future__ import annotations

from geometry_msgs.msg import Quaternion, Transform, TransformStamped, Vector3
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

from tensegrity_core.sim.simulator import Observation


def tf_msg(obs: Observation, hdr: Header, prefix: str = "") -> TFMessage:
    """world (``hdr.frame_id``) -> each moving body's frame (``prefix`` + its name), stamped
    ``hdr.stamp``."""
    out = TFMessage()
    for name, p, q in zip(obs.body_names, obs.body_positions, obs.body_orientations):
        out.transforms.append(TransformStamped(
            header=Header(stamp=hdr.stamp, frame_id=hdr.frame_id), child_frame_id=prefix + name,
            transform=Transform(translation=Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2])),
                                rotation=Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])))))
    return out
