"""Names of the class-2 mechanism's coordinates and actuators, spelt once.

The generalised coordinates are ``q = (rho1, rho2, beta)``: the lengths of actuators AB and
BC [m] and the angle beta [rad] (:mod:`.geometry`). They are the joints of the suite's
``sensor_msgs/JointState`` (rho1, rho2 prismatic, beta revolute), of which the two actuator
lengths are the joints a ``FollowActuatorTrajectory`` goal moves. The actuators are
``f1`` and ``f2``: their forces [N], positive tensile, as the scene's ``inputs`` and
``tensegrity_msgs/ActuatorForces`` name them.
"""

from __future__ import annotations

from typing import Final

#: The generalised coordinates ``q``, in order.
JOINTS: Final = ("rho1", "rho2", "beta")
#: The actuator lengths [m], in actuator order: the joints an actuator trajectory moves.
ACTUATED_JOINTS: Final = JOINTS[:2]
#: The actuators (their forces [N], positive tensile), in order.
ACTUATORS: Final = ("f1", "f2")
#: The state vector of the mechanism with inertia: ``q``, then its rates (the drive's states
#: follow, :class:`~tensegrity_core.class2.dynamics.drive.Drive`).
STATE_NAMES: Final = JOINTS + tuple(f"{j}_dot" for j in JOINTS)
