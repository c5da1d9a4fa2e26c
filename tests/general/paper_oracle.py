"""Test oracle: the paper's Euler 1-2-3 formulation, implemented as printed (corrected where
noted), to check its equations and to show where it differs from the exact formulation of
:mod:`tensegrity_core.general`.

Nothing in the package uses it. Conventions (verified in ``tests/general/test_paper_equations.py``):
``R(phi)`` of Eq. 24 equals ``R3(gamma) R2(beta) R1(alpha)`` with *passive* elementary
matrices, a body node is ``n = c + R^T p`` (Eq. 29, ``p`` the offset in the reference
drawing, which is the body frame at ``phi = 0``), and ``B`` of Eq. 37 maps Euler-angle
rates to the angular velocity in the *inertial* frame, ``omega = B phi_dot``.
``det B = cos(beta)``: singular at ``beta = +-pi/2`` (the paper's Sect. 2.2.1 says
``beta = 0``).
"""

from __future__ import annotations

import numpy as np

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.rotation import hat
from tensegrity_core.general.statics import generalized_force, internal_nodal_forces
from tensegrity_core.general.stiffness import stiffness_parts, sym_rotation_hessian
from tensegrity_core.general.structure import Structure


def euler_matrix(phi) -> np.ndarray:
    """Eq. 24 as printed: the attitude matrix ``R(alpha, beta, gamma)`` (passive)."""
    a, b, g = phi
    ca, sa, cb, sb, cg, sg = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(g), np.sin(g)
    return np.array([[cg * cb, cg * sb * sa + sg * ca, -cg * sb * ca + sg * sa],
                     [-sg * cb, -sg * sb * sa + cg * ca, sg * sb * ca + cg * sa],
                     [sb, -cb * sa, cb * ca]])


def euler_rate_matrix(phi) -> np.ndarray:
    """Eq. 37 as printed: ``B`` with ``omega = B phi_dot`` (inertial frame)."""
    a, b = phi[0], phi[1]
    return np.array([[1.0, 0.0, np.sin(b)],
                     [0.0, np.cos(a), -np.cos(b) * np.sin(a)],
                     [0.0, np.sin(a), np.cos(a) * np.cos(b)]])


def euler_configuration(structure: Structure, free, centres, phis) -> Configuration:
    """Configuration from Euler minimal coordinates: free node coordinates (n_free,),
    body centres (nb, 3), Euler angles (nb, 3); body nodes ``c + R(phi)^T p`` (Eqs. 28-29)."""
    lay = structure.layout
    coords = structure.nodes.copy()
    mask = lay.free_index >= 0
    coords[mask] = np.asarray(free, dtype=float)[lay.free_index[mask]]
    rotations = np.array([euler_matrix(p).T for p in np.reshape(phis, (-1, 3))]).reshape(-1, 3, 3)
    centres = np.reshape(np.asarray(centres, dtype=float), (-1, 3))
    for slot, idx in enumerate(lay.body_nodes):
        coords[idx] = centres[slot] + lay.offsets[idx] @ rotations[slot].T
    return Configuration(structure, coords, centres, rotations)


def euler_transform(structure: Structure, phis) -> np.ndarray:
    """``T = dU_rotvec / dU_euler``: identity except ``B(phi)`` in each rotation block, so
    the paper's ``G`` (Eqs. 41-43) is ``G_rotvec @ T``."""
    lay = structure.layout
    T = np.eye(lay.n_dof)
    for slot, phi in enumerate(np.reshape(phis, (-1, 3))):
        b = lay.body_dof[slot] + 3
        T[b:b + 3, b:b + 3] = euler_rate_matrix(phi)
    return T


def euler_generalized_force(config: Configuration, phis) -> np.ndarray:
    """The paper's generalised force ``-dV/dU`` in Euler coordinates (Eqs. 55, 58):
    ``B^T m`` in the rotation rows, ``m`` the moment about the body centre."""
    return euler_transform(config.structure, phis).T @ generalized_force(config.structure, config)


def paper_tangent_stiffness(config: Configuration, phis) -> np.ndarray:
    """``K_E + K_G`` of Eqs. 71-80 in Euler coordinates, as printed: the member part of
    Eq. 78 plus ``F_i`` of Eq. 79, whose body block is ``B^T hat(z) hat(r) B`` (not
    symmetric) -- no load stiffness and no derivative of ``B``."""
    s = config.structure
    parts = stiffness_parts(s, config)
    K = parts["KE"] + parts["KG"]
    lay = s.layout
    g_int = -internal_nodal_forces(s, config.coords)
    r = config.arms()
    for slot, idx in enumerate(lay.body_nodes):
        b = lay.body_dof[slot] + 3
        exact = sym_rotation_hessian(g_int[idx], r[idx]).sum(axis=0)
        printed = (hat(g_int[idx]) @ hat(r[idx])).sum(axis=0)
        K[b:b + 3, b:b + 3] += printed - exact
    T = euler_transform(s, phis)
    return T.T @ K @ T
