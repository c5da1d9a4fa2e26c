"""IMU readings of a rigid body, as a real strapdown IMU reports them.

An IMU fixed to a body at body-frame offset ``p`` [m] from the body's centre ``c`` reads,
in the body frame (``R``: body -> world, so body-frame vectors are ``R^T`` of world ones):

- orientation: the quaternion ``(x, y, z, w)`` of ``R`` (``sensor_msgs/Imu``'s order;
  ``w >= 0``);
- angular velocity ``R^T omega`` [rad/s] (``omega`` in world axes);
- specific force ``R^T (a_p - g)`` [m/s^2], the acceleration of the IMU's point minus
  gravity: a body at rest on the floor reads ``+|g|`` up, one in free fall reads 0.
  ``a_p = a_c + alpha x r + omega x (omega x r)`` with ``r = R p``.

The ROS node fills the messages' covariance fields; this module is noise-free.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.general.rotation import cross

FloatArray = NDArray[np.float64]


def imu_readings(R: ArrayLike, omega: ArrayLike, a_c: ArrayLike, alpha: ArrayLike, offset: ArrayLike,
                 gravity: ArrayLike, *, quaternions: ArrayLike | None = None
                 ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(quaternion (n, 4) xyzw, angular velocity (n, 3) [rad/s], specific force (n, 3)
    [m/s^2])`` in the body frames of bodies with rotations ``R`` (n, 3, 3), angular velocity
    ``omega`` and acceleration ``alpha`` [rad/s^2] (world axes), centre accelerations ``a_c``
    [m/s^2], IMU ``offset`` (n, 3) [m, body frame] and the ``gravity`` field (3,) [m/s^2].
    ``quaternions`` (n, 4) xyzw of ``R``, when the caller has them already (either sign)."""
    Rm = np.asarray(R, dtype=float).reshape(-1, 3, 3)
    w = np.asarray(omega, dtype=float).reshape(-1, 3)
    r = np.einsum("kij,kj->ki", Rm, np.asarray(offset, dtype=float).reshape(-1, 3))
    a_p = (np.asarray(a_c, dtype=float).reshape(-1, 3) + cross(np.asarray(alpha, dtype=float).reshape(-1, 3), r)
           + cross(w, cross(w, r)))
    to_body = np.swapaxes(Rm, 1, 2)
    quat = (Rotation.from_matrix(Rm).as_quat() if quaternions is None
            else np.asarray(quaternions, dtype=float).reshape(-1, 4))
    quat = np.where(quat[:, 3:4] < 0, -quat, quat)
    gyro: FloatArray = np.einsum("kij,kj->ki", to_body, w)
    specific: FloatArray = np.einsum("kij,kj->ki", to_body, a_p - np.asarray(gravity, dtype=float))
    return quat, gyro, specific
