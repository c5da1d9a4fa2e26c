"""The degrees of freedom of a structure: the numbering of ``U`` and the sparsity of matrices over it.

Both are fixed by the structure's topology, supports and rigid bodies (not by where it is),
so each :class:`~tensegrity_core.general.structure.Structure` builds them once, on first
use (``structure.layout``, ``structure.stiffness_pattern``):

- :class:`DofLayout`: which entry of the minimal coordinate ``U`` (see
  :mod:`~tensegrity_core.general.configuration`) each free node coordinate and each moving
  body's centre and rotation is;
- :class:`StiffnessPattern`: the sparsity pattern of the tangent stiffness ``K_T``
  (:mod:`~tensegrity_core.general.stiffness`) and its scatter-add assembly.

This module reads a structure through :class:`StructureView` (what it needs of one, as a
Protocol) and imports nothing of the package, so the structure can hold both without an
import circle.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray


class BodyView(Protocol):
    """What this module reads of a rigid body (a :class:`~tensegrity_core.general.structure.RigidBody`):
    its name, node indices, mass [kg] and whether it is fixed."""

    @property
    def name(self) -> str: ...

    @property
    def nodes(self) -> tuple[int, ...]: ...

    @property
    def mass(self) -> float: ...

    @property
    def fixed(self) -> bool: ...


class StructureView(Protocol):
    """What this module reads of a structure (a :class:`~tensegrity_core.general.structure.Structure`):
    nodes (names, reference coordinates [m], pinned axes), members (node index pairs), rigid
    bodies and the structure's own :class:`DofLayout`."""

    @property
    def n_nodes(self) -> int: ...

    @property
    def node_names(self) -> tuple[str, ...]: ...

    @property
    def nodes(self) -> NDArray[np.float64]: ...

    @property
    def pinned(self) -> NDArray[np.bool_]: ...

    @property
    def members(self) -> NDArray[np.int64]: ...

    @property
    def bodies(self) -> Sequence[BodyView]: ...

    @property
    def layout(self) -> DofLayout: ...


class DofLayout:
    """Index bookkeeping of the minimal coordinate ``U`` of a structure (built once per structure).

    Attributes: ``n_dof``; ``free_index`` (n, 3) int, the ``U`` index of each free node
    coordinate or -1; ``node_body`` (n,) int, the moving-body slot of each node or -1;
    ``body_dof`` (nb,) int, the ``U`` index of each moving body's centre (its rotation
    follows at +3); ``moving_bodies`` the structure's body indices that move;
    ``offsets`` (n, 3) body-frame offsets ``p_j`` of body nodes (zero elsewhere);
    ``fixed_mask`` (n, 3) bool, coordinates that never move; ``body_radii`` (nb,) the
    largest node distance from each body's centre [m]. Derived once, for the per-step
    kernels (each numpy call on these small arrays costs a microsecond): ``free_mask`` (n, 3)
    ``free_index >= 0``; ``free_dofs`` the ``U`` indices of ``free_index[free_mask]``;
    ``on_body`` (n,) bool, nodes of moving bodies; ``body_slot`` their ``node_body``;
    ``body_dofs`` (nb, 6) the ``U`` indices of each moving body (centre, then rotation).
    """

    def __init__(self, structure: StructureView) -> None:
        n = structure.n_nodes
        self.moving_bodies = tuple(k for k, b in enumerate(structure.bodies) if not b.fixed)
        node_body = np.full(n, -1, dtype=np.int64)
        fixed_mask = structure.pinned.copy()
        for body in structure.bodies:
            if body.fixed:
                fixed_mask[list(body.nodes)] = True
        for slot, k in enumerate(self.moving_bodies):
            node_body[list(structure.bodies[k].nodes)] = slot
        free = (node_body[:, None] < 0) & ~fixed_mask
        free_index = np.full((n, 3), -1, dtype=np.int64)
        n_free = int(free.sum())
        free_index[free] = np.arange(n_free)
        nb = len(self.moving_bodies)
        self.body_dof = n_free + 6 * np.arange(nb, dtype=np.int64)
        self.n_free = n_free
        self.n_dof = n_free + 6 * nb
        self.free_index = free_index
        self.node_body = node_body
        self.fixed_mask = fixed_mask
        self.body_nodes = tuple(np.asarray(structure.bodies[k].nodes, dtype=np.int64)
                                for k in self.moving_bodies)
        offsets = np.zeros((n, 3))
        ref_centres = np.zeros((nb, 3))
        for slot, idx in enumerate(self.body_nodes):
            ref_centres[slot] = structure.nodes[idx].mean(axis=0)
            offsets[idx] = structure.nodes[idx] - ref_centres[slot]
        self.offsets = offsets
        self.ref_centres = ref_centres
        self.body_radii = np.array([np.linalg.norm(offsets[idx], axis=1).max() for idx in self.body_nodes])
        self.body_sizes = np.array([len(idx) for idx in self.body_nodes], dtype=float)
        self.body_masses = np.array([structure.bodies[k].mass for k in self.moving_bodies])
        # U indices touched by each node: 6 slots (x, y, z, tx, ty, tz) with -1 where unused.
        node_dofs = np.full((n, 6), -1, dtype=np.int64)
        node_dofs[:, :3] = free_index
        on_body = node_body >= 0
        base = self.body_dof[node_body[on_body]]
        node_dofs[on_body] = base[:, None] + np.arange(6)[None, :]
        self.node_dofs = node_dofs
        self.free_mask = free_index >= 0
        self.free_dofs = free_index[self.free_mask]
        self.on_body = on_body
        self.body_slot = node_body[on_body]
        self.body_dofs = self.body_dof[:, None] + np.arange(6)[None, :]
        self.names = structure.node_names
        self.body_names = tuple(structure.bodies[k].name for k in self.moving_bodies)

    def labels(self) -> list[str]:
        """Human-readable name of every entry of ``U`` (e.g. ``"t1.z"``, ``"top.rx"``)."""
        out = [""] * self.n_dof
        for i, j in zip(*np.nonzero(self.free_index >= 0)):
            out[self.free_index[i, j]] = f"{self.names[i]}.{'xyz'[j]}"
        for slot, name in enumerate(self.body_names):
            for j, s in enumerate(("cx", "cy", "cz", "rx", "ry", "rz")):
                out[self.body_dof[slot] + j] = f"{name}.{s}"
        return out


class StiffnessPattern:
    """Sparsity pattern of ``K_T`` (fixed by the topology) and a fast scatter-add assembly.

    Element entries (12 x 12 per member, 3 x 3 per moving body) are summed into CSR storage
    with one ``bincount`` per assembly; the pattern is built once per structure.
    """

    def __init__(self, structure: StructureView) -> None:
        lay = structure.layout
        n = lay.n_dof
        a, b = structure.members[:, 0], structure.members[:, 1]
        dofs = np.concatenate([lay.node_dofs[a], lay.node_dofs[b]], axis=1)      # (m, 12)
        self.elem_keep = (dofs[:, :, None] >= 0) & (dofs[:, None, :] >= 0)
        rows = np.broadcast_to(dofs[:, :, None], self.elem_keep.shape)[self.elem_keep]
        cols = np.broadcast_to(dofs[:, None, :], self.elem_keep.shape)[self.elem_keep]
        tdofs = lay.body_dof[:, None] + 3 + np.arange(3)[None, :]                  # (nb, 3)
        brows = np.broadcast_to(tdofs[:, :, None], (len(tdofs), 3, 3)).ravel()
        bcols = np.broadcast_to(tdofs[:, None, :], (len(tdofs), 3, 3)).ravel()
        keys = np.concatenate([rows, brows]).astype(np.int64) * n + np.concatenate([cols, bcols])
        uniq, self.inverse = np.unique(keys, return_inverse=True)
        self.indices = (uniq % n).astype(np.int32)
        self.indptr = np.searchsorted(uniq // n, np.arange(n + 1)).astype(np.int32)
        self.shape = (n, n)
        self.nnz = uniq.size

    def assemble(self, elements: NDArray[np.float64], body_blocks: NDArray[np.float64]) -> sp.csr_matrix:
        """CSR matrix from member element matrices (m, 12, 12) and body rotation blocks (nb, 3, 3)."""
        w = np.concatenate([elements[self.elem_keep], body_blocks.ravel()])
        data = np.bincount(self.inverse, weights=w, minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=self.shape)
