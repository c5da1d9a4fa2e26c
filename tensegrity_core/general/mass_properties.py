"""Mass properties of a structure's lumped masses, as a rigid-body simulator wants them.

The general dynamics (:mod:`tensegrity_core.sim.general.model`) lumps every mass on the
nodes: a free node carries its point mass, half of each attached member's mass and nothing
else; a moving rigid body carries the lumped masses of its nodes (its own mass shared
equally by them). A body's frame here is the one of the general dynamics: origin at the
centroid ``c`` of its nodes, axes those of the reference drawing (node ``k`` at the offset
``p_k`` from ``c``). Its mass properties are those of its point masses ``m_k`` at ``p_k``::

    m = sum m_k,   com = sum m_k p_k / m,   I_com = sum m_k (|r_k|^2 I - r_k r_k^T),  r_k = p_k - com

(a full tensor: point masses rarely sit on principal axes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.dofs import DofLayout
from tensegrity_core.general.rotation import hat
from tensegrity_core.general.structure import Structure

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class BodyInertia:
    """A moving rigid body's mass [kg], centre of mass ``com`` (3,) [m] and inertia ``inertia``
    (3, 3) about the centre of mass [kg m^2], both in the body frame (origin at the node
    centroid, axes of the reference drawing)."""

    mass: float
    com: FloatArray
    inertia: FloatArray

    def inertia_about_origin(self) -> FloatArray:
        """(3, 3) inertia about the body frame's origin, the node centroid [kg m^2]."""
        d = self.com
        shifted: FloatArray = self.inertia + self.mass * (float(d @ d) * np.eye(3) - np.outer(d, d))
        return shifted


def body_inertias(structure: Structure, node_masses: FloatArray) -> list[BodyInertia]:
    """The mass properties of each moving body (``structure.layout.moving_bodies`` order) of the
    lumped ``node_masses`` (n,) [kg]."""
    return layout_inertias(structure.layout, node_masses)


def layout_inertias(lay: DofLayout, node_masses: FloatArray) -> list[BodyInertia]:
    """The mass properties of each moving body of the layout ``lay`` (its ``moving_bodies``
    order) of the lumped ``node_masses`` (n,) [kg]."""
    out = []
    for idx in lay.body_nodes:
        m = node_masses[idx]
        p = lay.offsets[idx]
        mass = float(m.sum())
        com = (m[:, None] * p).sum(axis=0) / mass
        r = p - com
        inertia = np.einsum("k,kij->ij", m, np.einsum("ki,ki->k", r, r)[:, None, None] * np.eye(3)
                            - np.einsum("ki,kj->kij", r, r))
        out.append(BodyInertia(mass, com, inertia))
    return out


def mass_matrix(structure: Structure, node_masses: FloatArray, config: Configuration) -> sp.csr_matrix:
    """The mass matrix ``M`` (n_dof, n_dof) over the rates of the minimal coordinate ``U`` at
    ``config`` (free node velocities, body centre velocities and world angular velocities):
    a diagonal of node masses and per body ``[[m I, -hat(s)], [hat(s), I_c]]`` with the first
    moment ``s = R m com`` and ``I_c = R I_origin R^T`` (kinetic energy ``v^T M v / 2``)."""
    lay = structure.layout
    n = lay.n_dof
    free_nodes, free_axes = np.nonzero(lay.free_index >= 0)
    diag = np.zeros(n)
    diag[lay.free_index[free_nodes, free_axes]] = node_masses[free_nodes]
    rows, cols, vals = [np.arange(n)], [np.arange(n)], [diag]
    for slot, body in enumerate(body_inertias(structure, node_masses)):
        R = config.rotations[slot]
        s = R @ (body.mass * body.com)
        block = np.zeros((6, 6))
        block[:3, :3] = body.mass * np.eye(3)
        block[:3, 3:] = -hat(s)
        block[3:, :3] = hat(s)
        block[3:, 3:] = R @ body.inertia_about_origin() @ R.T
        dofs = lay.body_dof[slot] + np.arange(6)
        rows.append(np.repeat(dofs, 6))
        cols.append(np.tile(dofs, 6))
        vals.append(block.ravel())
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
