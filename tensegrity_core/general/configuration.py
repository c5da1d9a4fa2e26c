"""Degrees of freedom and configurations: minimal coordinates with rotation-vector increments.

The minimal coordinate ``U`` (the paper's Eq. 30) stacks

1. the free coordinates of the nodes that are not on a moving rigid body (node order, then
   x, y, z; pinned axes are left out), then
2. for each moving rigid body, in description order, its centre ``c`` (mean of its nodes,
   Eq. 25) [m] and a rotation-vector *increment* ``dtheta`` [rad] about world axes through
   ``c``.

A configuration stores the free coordinates, each body's centre and its orientation matrix
``R`` (active, body frame = the reference drawing). A body node is ``n_j = c + R p_j`` with
``p_j`` its offset from the centroid in the reference coordinates. An increment ``dU`` is
applied by :meth:`Configuration.retract`: free coordinates and centres add,
``R <- exp(hat(dtheta)) R``. Derivatives are taken at ``dtheta = 0``, so the transformation
``G = dn/dU`` (Eq. 43) has the blocks ``[I, -hat(r_j)]`` with ``r_j = R p_j`` for body nodes
and is never singular -- unlike the Euler 1-2-3 angles of the paper, whose ``B_i`` (Eq. 37)
loses rank at ``beta = +-pi/2``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.excerpt import excerpt
from tensegrity_core.general.rotation import best_fit_rotation, exp_so3, hat
from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.schema import MAX_MAGNITUDE


def node_coordinates(structure: Structure, coords: ArrayLike, *, batch: bool = False) -> NDArray[np.float64]:
    """``coords`` as float node coordinates [m] of shape ``(n, 3)`` (``batch``: ``(..., n, 3)``).

    :class:`StructureError` naming ``coords`` unless every entry is a finite number of at most
    :data:`~tensegrity_core.schema.MAX_MAGNITUDE` in magnitude (as in a structure file: larger
    values overflow the squares the solvers form).
    """
    try:
        xyz = np.asarray(coords, dtype=np.float64)
    except (TypeError, ValueError):
        raise StructureError(f"coords must be an array of numbers [m], got {excerpt(coords)}",
                             entry=("coords",)) from None
    n = structure.n_nodes
    if xyz.shape[-2:] != (n, 3) or (xyz.ndim != 2 and not batch):
        want = f"(..., {n}, 3)" if batch else f"({n}, 3)"
        raise StructureError(f"coords must have shape {want}, got {xyz.shape}", entry=("coords",))
    bad = ~(np.isfinite(xyz) & (np.abs(xyz) <= MAX_MAGNITUDE))
    if bad.any():
        row = tuple(int(k) for k in np.argwhere(bad)[0][:-1])
        name = structure.node_names[row[-1]]
        raise StructureError(f"coords contain non-finite values or values beyond {MAX_MAGNITUDE:g} m: node "
                             f"{excerpt(name)} at {excerpt(xyz[row].tolist())}", entry=("coords", name))
    return xyz


def check_member_lengths(structure: Structure, coords: NDArray[np.float64]) -> None:
    """:class:`StructureError` naming the first member whose two nodes coincide in ``coords``
    (length at most ``1e-12`` times the extent of ``coords``, the test of a structure file):
    its direction, so the equilibrium matrix and the stiffness, do not exist there."""
    a, b = structure.members[:, 0], structure.members[:, 1]
    scale = max(float(np.ptp(coords, axis=0).max()), 1e-300)
    short = np.flatnonzero(np.linalg.norm(coords[b] - coords[a], axis=1) <= 1e-12 * scale)
    if short.size:
        i = int(short[0])
        raise StructureError(
            f"member {excerpt(structure.member_names[i])} has zero length in coords: nodes "
            f"{excerpt(structure.node_names[a[i]])} and {excerpt(structure.node_names[b[i]])} are both at "
            f"{coords[a[i]].tolist()}", entry=("coords", structure.member_names[i]))


@dataclass(frozen=True, eq=False)
class Configuration:
    """A placement of a structure: node coordinates plus each moving body's centre and
    orientation. Immutable; :meth:`retract` returns a new configuration."""

    structure: Structure
    coords: NDArray[np.float64]      # (n, 3) node coordinates [m]
    centres: NDArray[np.float64]     # (nb, 3) moving-body centres [m]
    rotations: NDArray[np.float64]   # (nb, 3, 3) active rotation from the reference drawing

    @classmethod
    def initial(cls, structure: Structure) -> Configuration:
        """The reference drawing itself (every body at its reference orientation)."""
        lay = structure.layout
        nb = len(lay.moving_bodies)
        return cls(structure, structure.nodes.copy(), lay.ref_centres.copy(),
                   np.broadcast_to(np.eye(3), (nb, 3, 3)).copy())

    @classmethod
    def from_coords(cls, structure: Structure, coords: ArrayLike, *, rigid_tol: float = 1e-5) -> Configuration:
        """The configuration with node coordinates ``coords`` (n, 3) [m].

        Each moving body's orientation is the best-fit rotation of its reference shape; the
        body nodes must be a rigid motion of the reference shape within ``rigid_tol`` times
        the body size (else :class:`StructureError`), and are then placed exactly. Fixed
        coordinates (pinned axes, fixed bodies) keep the values given in ``coords``.
        """
        xyz = node_coordinates(structure, coords).copy()
        lay = structure.layout
        nb = len(lay.moving_bodies)
        centres = np.zeros((nb, 3))
        rotations = np.zeros((nb, 3, 3))
        for slot, idx in enumerate(lay.body_nodes):
            c = xyz[idx].mean(axis=0)
            R, misfit = best_fit_rotation(lay.offsets[idx], xyz[idx] - c)
            size = np.sqrt(np.mean(np.sum(lay.offsets[idx] ** 2, axis=1)))
            if misfit > rigid_tol * size:
                raise StructureError(
                    f"coords deform rigid body {lay.body_names[slot]!r}: its nodes are "
                    f"{misfit:.3g} m (RMS) from a rigid placement of its reference shape")
            centres[slot], rotations[slot] = c, R
            xyz[idx] = c + lay.offsets[idx] @ R.T
        return cls(structure, xyz, centres, rotations)

    def retract(self, dU: ArrayLike) -> Configuration:
        """The configuration moved by the increment ``dU`` (n_dof,): free coordinates and
        centres add, orientations turn by ``exp(hat(dtheta))`` on the left."""
        lay = self.structure.layout
        dU = np.asarray(dU, dtype=float)
        coords = self.coords.copy()
        coords[lay.free_mask] += dU[lay.free_dofs]
        if lay.body_dof.size:
            d = dU[lay.body_dofs]
            centres = self.centres + d[:, :3]
            rotations = exp_so3(d[:, 3:]) @ self.rotations
            on, slot = lay.on_body, lay.body_slot
            coords[on] = centres[slot] + np.einsum("kij,kj->ki", rotations[slot], lay.offsets[on])
        else:
            centres, rotations = self.centres, self.rotations
        return Configuration(self.structure, coords, centres, rotations)

    def arms(self) -> NDArray[np.float64]:
        """(n, 3) world-frame offsets ``r_j = n_j - c`` of body nodes from their body centre
        (zero for other nodes)."""
        lay = self.structure.layout
        r = np.zeros_like(self.coords)
        on = lay.on_body
        r[on] = self.coords[on] - self.centres[lay.body_slot]
        return r


def transformation_matrix(config: Configuration) -> sp.csr_matrix:
    """``G = dn/dU`` (3n, n_dof) at ``dtheta = 0`` (Eq. 43 with the rotation-vector increment):
    identity rows for free coordinates, ``[I, -hat(r_j)]`` for body nodes, zero rows for
    fixed coordinates. Rows are ordered node by node (x, y, z), like ``n = vec(N)``."""
    lay = config.structure.layout
    n = config.structure.n_nodes
    J = node_jacobians(config)                      # (n, 3, 6)
    rows = np.repeat(np.arange(3 * n).reshape(n, 3, 1), 6, axis=2)
    cols = np.broadcast_to(lay.node_dofs[:, None, :], (n, 3, 6))
    keep = (cols >= 0) & (J != 0)
    return sp.csr_matrix((J[keep], (rows[keep], cols[keep])), shape=(3 * n, lay.n_dof))


def node_jacobians(config: Configuration) -> NDArray[np.float64]:
    """(n, 3, 6) local Jacobians ``dn_j / d(local dofs)`` matching ``layout.node_dofs``:
    ``[I, 0]`` restricted to free axes for tensegrity nodes, ``[I, -hat(r_j)]`` for body nodes."""
    lay = config.structure.layout
    n = config.structure.n_nodes
    J = np.zeros((n, 3, 6))
    free = lay.free_index >= 0
    J[:, :3, :3] = np.eye(3)[None] * free[:, None, :]
    on = lay.node_body >= 0
    J[on, :3, :3] = np.eye(3)
    J[on, :, 3:] = -hat(config.arms()[on])
    return J
