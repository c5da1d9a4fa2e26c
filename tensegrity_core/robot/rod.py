"""Rods: rigid bodies between two end caps, their mass and inertia, and their body frame.

A rod runs from end cap ``a`` to end cap ``b`` (node positions; length ``L = |b - a|`` [m]).
Its body is a **capsule** of mass ``m`` and radius ``r`` (a solid cylinder of length ``L``
between the cap centres closed by two solid hemispheres, uniform density: the shape MuJoCo
gives a ``capsule`` geom) plus two **end caps**, solid spheres of mass ``m_c`` and radius
``r_c`` centred on the rod's ends (the contact spheres; motors and electronics are usually
lumped there). Every part is symmetric about the rod's centre, so the centre of mass is
the midpoint and the inertia about it is ``diag(I_t, I_t, I_a)`` in the rod frame:

- capsule (``m_cyl = m V_cyl / V``, ``m_hs = m V_sph / V``; ``V_cyl = pi r^2 L``,
  ``V_sph = 4/3 pi r^3``, ``V = V_cyl + V_sph``):
  ``I_a = m_cyl r^2 / 2 + m_hs 2 r^2 / 5``,
  ``I_t = m_cyl (L^2/12 + r^2/4) + m_hs (2 r^2/5 + L^2/4 + 3 L r / 8)``
  (each hemisphere's inertia about its flat face is that of the sphere per unit mass; its
  centroid is ``3 r / 8`` from the face; parallel axes);
- caps: ``I_a = 2 m_c 2 r_c^2 / 5``, ``I_t = 2 m_c (2 r_c^2 / 5 + L^2 / 4)``.

**Why a physical axial inertia (6 degrees of freedom), not a 5-DOF rod.** A slender rod
(``r = 0``, point caps) has ``I_a = 0``: its mass matrix is singular about its axis. The
rods here keep their physical ``I_a > 0`` (the description refuses a rod without one)
because (1) the floor's friction acts on the caps' surfaces, ``r_c`` off the axis, so a rod
that rolls on its caps really spins about its axis, and that spin carries the friction's
moment; (2) an IMU's gyro measures the spin; (3) MuJoCo gives capsules their physical
inertia, so the exported model and its cross-check see the same body; (4) one 6-DOF rigid
body serves rods, vertebrae and every other body alike (one kernel, one chart). The price
is a fast spin mode, ``omega^2 = k_t r_c^2 / I_a`` under the contact's tangential stiffness
``k_t``; docs/robots.md sizes it for the 1 kHz loop. Cables attach at the cap centres, on
the axis, so they exert no moment about it.

**Rod frame.** The body frame has its origin at the rod's centre and its z axis along
``b - a``; x is the unit vector of world x (world y if the rod is within 1e-6 rad of
world x) made perpendicular to z, y = z x x. :func:`rod_frames` gives the frames of rods
as drawn; the frame then turns with the rod (it is body-fixed).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def capsule_inertia(mass: ArrayLike, radius: ArrayLike, length: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(I_t, I_a)`` [kg m^2] about the centre of uniform capsules of ``mass`` [kg],
    ``radius`` [m] and cylinder ``length`` [m] (between the hemispheres' centres);
    vectorised. ``radius = 0`` is the slender rod, ``(m L^2 / 12, 0)``."""
    m = np.asarray(mass, dtype=float)
    r = np.asarray(radius, dtype=float)
    L = np.asarray(length, dtype=float)
    v_cyl = math.pi * r * r * L
    v_sph = 4.0 / 3.0 * math.pi * r**3
    total = v_cyl + v_sph
    share = np.divide(v_cyl, total, out=np.ones_like(total), where=total > 0)
    m_cyl = m * share
    m_hs = m - m_cyl
    I_a = m_cyl * r * r / 2.0 + m_hs * 2.0 * r * r / 5.0
    I_t = m_cyl * (L * L / 12.0 + r * r / 4.0) + m_hs * (2.0 * r * r / 5.0 + L * L / 4.0 + 3.0 * L * r / 8.0)
    return I_t, I_a


def end_caps_inertia(cap_mass: ArrayLike, cap_radius: ArrayLike, length: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(I_t, I_a)`` [kg m^2] about the rod's centre of two solid spheres of ``cap_mass``
    [kg] each and ``cap_radius`` [m], centred ``length / 2`` [m] from it; vectorised."""
    mc = np.asarray(cap_mass, dtype=float)
    rc = np.asarray(cap_radius, dtype=float)
    L = np.asarray(length, dtype=float)
    own = 2.0 * rc * rc / 5.0
    I_t: FloatArray = 2.0 * mc * (own + L * L / 4.0)
    I_a: FloatArray = 2.0 * mc * own
    return I_t, I_a


def rod_inertia(mass: ArrayLike, radius: ArrayLike, cap_mass: ArrayLike, cap_radius: ArrayLike,
                length: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(I_t, I_a)`` [kg m^2] about the centre of rods made of a capsule (``mass``,
    ``radius``) and two end caps (``cap_mass`` each, ``cap_radius``), ``length`` [m]
    between the cap centres; vectorised (see the module docstring)."""
    t1, a1 = capsule_inertia(mass, radius, length)
    t2, a2 = end_caps_inertia(cap_mass, cap_radius, length)
    return t1 + t2, a1 + a2


def rod_frames(ends_a: ArrayLike, ends_b: ArrayLike) -> FloatArray:
    """(r, 3, 3) rotations (body -> world, columns x, y, z) of rods from ``ends_a`` to
    ``ends_b`` ((r, 3) [m]): z along the rod, x from world x (world y for a rod along x)."""
    a = np.asarray(ends_a, dtype=float).reshape(-1, 3)
    b = np.asarray(ends_b, dtype=float).reshape(-1, 3)
    h = b - a
    z = h / np.linalg.norm(h, axis=1, keepdims=True)
    along_x = np.abs(z[:, 0]) > math.cos(1e-6)
    ref = np.where(along_x[:, None], np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    x = ref - np.sum(ref * z, axis=1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=2)


def world_inertia(frames: ArrayLike, I_t: ArrayLike, I_a: ArrayLike) -> FloatArray:
    """(r, 3, 3) inertia tensors [kg m^2] about the rods' centres in world axes:
    ``R diag(I_t, I_t, I_a) R^T`` for frames ``R`` (r, 3, 3)."""
    R = np.asarray(frames, dtype=float)
    t = np.asarray(I_t, dtype=float)
    a = np.asarray(I_a, dtype=float)
    z = R[..., :, 2]
    # diag(I_t, I_t, I_a) = I_t 1 + (I_a - I_t) e_z e_z^T, turned: I_t 1 + (I_a - I_t) z z^T
    out: FloatArray = (t[..., None, None] * np.eye(3)
                       + (a - t)[..., None, None] * np.einsum("...i,...j->...ij", z, z))
    return out
