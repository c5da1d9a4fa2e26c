"""Rotations: skew matrices, the exponential map, the best-fit rotation of point sets, the
scipy ``Rotation`` of exact rotation matrices, and the cross product over arrays of vectors.
(The left Jacobian of SO(3) that the dynamics' rotation charts need lives with their
kernels, ``sim/general/kernels``.)

Conventions: rotation matrices are *active* (``x_world = R @ x_body``); a rotation vector
``theta`` [rad] has direction = axis (right-hand rule) and norm = angle. Orientation
increments are applied on the left, ``R_new = exp(hat(dtheta)) @ R`` (spatial frame), so
``dtheta`` is an infinitesimal rotation about world axes through the body centre.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

FloatArray = NDArray[np.float64]


def hat(v: ArrayLike) -> NDArray[np.float64]:
    """Skew-symmetric matrix of ``v`` (shape ``(..., 3)`` -> ``(..., 3, 3)``): ``hat(a) b = a x b``."""
    v = np.asarray(v, dtype=np.float64)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def exp_so3(theta: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix ``exp(hat(theta))`` by Rodrigues' formula, vectorised over ``(..., 3)``.

    Uses the Taylor series of ``sin(a)/a`` and ``(1 - cos a)/a^2`` below ``a = 1e-4`` rad so
    the result is accurate to rounding for every angle, including zero.
    """
    theta = np.asarray(theta, dtype=np.float64)
    a2 = np.sum(theta * theta, axis=-1)
    a = np.sqrt(a2)
    small = a < 1e-4
    safe = np.where(small, 1.0, a)
    s = np.where(small, 1.0 - a2 / 6.0 + a2 * a2 / 120.0, np.sin(safe) / safe)
    c = np.where(small, 0.5 - a2 / 24.0 + a2 * a2 / 720.0, (1.0 - np.cos(safe)) / (safe * safe))
    K = hat(theta)
    eye = np.broadcast_to(np.eye(3), K.shape)
    R: NDArray[np.float64] = eye + s[..., None, None] * K + c[..., None, None] * (K @ K)
    return R


def best_fit_rotation(reference: ArrayLike, current: ArrayLike) -> tuple[NDArray[np.float64], float]:
    """Proper rotation ``R`` minimising ``sum |R p_j - q_j|^2`` (Kabsch), and the RMS misfit [m].

    ``reference`` and ``current`` are ``(k, 3)`` point sets, each already centred on its
    mean. The misfit is zero when ``current`` is an exact rotation of ``reference``.
    """
    P = np.asarray(reference, dtype=float)
    Q = np.asarray(current, dtype=float)
    R = best_fit_rotations(P, Q[None])[0]
    misfit = float(np.sqrt(np.mean(np.sum((P @ R.T - Q) ** 2, axis=1))))
    return R, misfit


def best_fit_rotations(reference: ArrayLike, current: ArrayLike) -> NDArray[np.float64]:
    """:func:`best_fit_rotation` of one ``reference`` (k, 3) onto each of a stack of point
    sets ``current`` (b, k, 3), all centred on their means: the proper rotations (b, 3, 3)
    (a reflection ruled out), in one batched SVD."""
    P = np.asarray(reference, dtype=float)
    Q = np.asarray(current, dtype=float)
    U, _, Vt = np.linalg.svd(np.einsum("bki,kj->bij", Q, P))
    d = np.sign(np.linalg.det(U @ Vt))
    D = np.ones((len(Q), 3))
    D[:, 2] = np.where(d != 0, d, 1.0)
    R: NDArray[np.float64] = (U * D[:, None, :]) @ Vt
    return R


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a x b`` over the last axis (numpy's ``cross`` costs ~20 us per call in overhead)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], -1)


def exact_rotations(R: ArrayLike) -> Rotation:
    """The scipy ``Rotation`` of rotation matrices ``R`` (..., 3, 3) that are orthonormal with
    determinant +1 to rounding, as every rotation the simulator carries is (an exponential map
    times a reference rotation): scipy's projection of an arbitrary matrix onto the nearest
    rotation, which costs ~5x the conversion itself, is skipped."""
    return Rotation.from_matrix(R, assume_valid=True)
