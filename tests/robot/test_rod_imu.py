"""Rod inertia against numerical integration over the body's volume, the rod frame, and IMU
readings against finite differences of a rotating body's motion."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.spatial.transform import Rotation

from tensegrity_core.general.rotation import exp_so3, hat
from tensegrity_core.robot import imu, rod


def capsule_by_quadrature(mass, r, L):
    """(I_t, I_a) of a uniform capsule by integrating slices along its axis: a disc of
    radius R(z) contributes pi R^4 / 2 dz about the axis and (pi R^4 / 4 + pi R^2 z^2) dz
    about a transverse axis (per unit density)."""
    def R(z):
        z = abs(z)
        return r if z <= L / 2 else np.sqrt(max(r * r - (z - L / 2) ** 2, 0.0))

    ends = (-L / 2 - r, L / 2 + r)
    pts = [-L / 2, L / 2]
    vol = quad(lambda z: np.pi * R(z) ** 2, *ends, points=pts, epsabs=0, epsrel=1e-13)[0]
    axial = quad(lambda z: np.pi * R(z) ** 4 / 2, *ends, points=pts, epsabs=0, epsrel=1e-13)[0]
    trans = quad(lambda z: np.pi * R(z) ** 4 / 4 + np.pi * R(z) ** 2 * z * z, *ends, points=pts,
                 epsabs=0, epsrel=1e-13)[0]
    rho = mass / vol
    return rho * trans, rho * axial


@pytest.mark.parametrize("mass, r, L", [(1.0, 0.0381, 1.376), (2.5, 0.1, 0.5), (0.3, 0.01, 2.0)])
def test_capsule_inertia_matches_integration(mass, r, L):
    I_t, I_a = rod.capsule_inertia(mass, r, L)
    t_ref, a_ref = capsule_by_quadrature(mass, r, L)
    assert abs(I_t - t_ref) <= 1e-10 * t_ref
    assert abs(I_a - a_ref) <= 1e-10 * a_ref


def test_limits_slender_rod_and_caps():
    I_t, I_a = rod.capsule_inertia(3.0, 0.0, 2.0)
    assert I_t == 3.0 * 4.0 / 12 and I_a == 0.0                          # m L^2 / 12, no axial inertia
    t, a = rod.end_caps_inertia(0.5, 0.0675, 1.376)
    assert abs(t - 2 * 0.5 * (0.688**2 + 0.4 * 0.0675**2)) < 1e-15        # parallel axes
    assert abs(a - 2 * 0.5 * 0.4 * 0.0675**2) < 1e-18
    t, a = rod.rod_inertia(1.0, 0.02, 0.5, 0.05, 1.0)
    assert a > 0.0                                                         # the axial inertia is physical


def test_rod_frames_are_right_handed_with_z_along_the_rod():
    rng = np.random.default_rng(6)
    a = rng.normal(size=(20, 3))
    b = a + rng.normal(size=(20, 3))
    b[0] = a[0] + [2.0, 0.0, 0.0]                                          # along world x
    R = rod.rod_frames(a, b)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    np.testing.assert_allclose(R[:, :, 2], (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True), atol=1e-14)
    I = rod.world_inertia(R, 2.0, 0.1)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", I, R[:, :, 2]), 0.1 * R[:, :, 2], atol=1e-14)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", I, R[:, :, 0]), 2.0 * R[:, :, 0], atol=1e-14)


def test_imu_readings_against_finite_differences_of_the_motion():
    """A body turning at a constant world rate omega about its centre, which moves with a
    constant acceleration: the IMU point's world trajectory x(t) = c(t) + R(t) p, differenced
    twice, gives its acceleration; R^T dR/dt gives the body rate."""
    g = np.array([0.0, 0.0, -9.81])
    omega = np.array([0.4, -1.1, 2.3])
    a_c = np.array([0.3, 0.0, -1.0])
    R0 = Rotation.from_rotvec([0.3, 0.5, -0.2]).as_matrix()
    p = np.array([0.05, -0.02, 0.6])

    def R(t):
        return exp_so3(omega * t) @ R0

    def x(t):
        return 0.5 * a_c * t * t + R(t) @ p

    t, h = 0.7, 1e-4
    acc = (x(t + h) - 2 * x(t) + x(t - h)) / h**2
    dR = (R(t + h) - R(t - h)) / (2 * h)
    body_rate = R(t).T @ dR
    quat, gyro, specific = imu.imu_readings(R(t)[None], omega, a_c, np.zeros(3), p, g)
    np.testing.assert_allclose(specific[0], R(t).T @ (acc - g), atol=1e-6)
    np.testing.assert_allclose(hat(gyro[0]), body_rate, atol=1e-8)
    # the quaternion rotates body vectors like R (Hamilton product, by hand)
    qx, qy, qz, qw = quat[0]
    u, w = np.array([qx, qy, qz]), np.array([1.0, 2.0, 3.0])
    rotated = w + 2 * qw * np.cross(u, w) + 2 * np.cross(u, np.cross(u, w))
    np.testing.assert_allclose(rotated, R(t) @ w, atol=1e-12)
    assert qw >= 0


def test_imu_at_rest_reads_gravity_up_and_nothing_in_free_fall():
    g = np.array([0.0, 0.0, -9.81])
    R = Rotation.from_rotvec([0.0, np.pi / 2, 0.0]).as_matrix()           # body z along world x
    _, gyro, rest = imu.imu_readings(R[None], np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), g)
    np.testing.assert_allclose(rest[0], R.T @ [0.0, 0.0, 9.81], atol=1e-15)
    np.testing.assert_allclose(gyro[0], 0.0)
    _, _, falling = imu.imu_readings(R[None], np.zeros(3), g, np.zeros(3), np.zeros(3), g)
    np.testing.assert_allclose(falling[0], 0.0, atol=1e-15)
