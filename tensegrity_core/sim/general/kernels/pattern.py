"""The sparsity pattern of a general model's Jacobian, fixed by its topology, built once.

The Jacobian ``d(dy/dt)/dy`` of ``y = (x, v)`` has three non-zero quadrants::

    [[0,                T          ],     T   = d(dx/dt)/dv = blockdiag(I, J_l(theta)^-1)
     [-M^-1 K_T C,  -M^-1 (D + G)  ]]     (see the docstring of the model module)

Its coordinates fall into *groups*: the free coordinates of one node (1 to 3) and the six of
one moving body. ``M^-1`` is block diagonal over the groups, ``C = blockdiag(I, J_l)``
too, and ``K_T`` and ``D`` couple two groups only through a member between them, so every
quadrant is a set of dense *blocks* (group, group): one per group on the diagonal and one
per pair of groups a member joins. The kernels (:mod:`.loops`, :mod:`.arrays`) compute the
blocks padded to 6 x 6; :attr:`JacobianPattern.source` picks each stored entry of the CSC
matrix out of them, so the values land in CSC order with one gather.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels.plan import Plan

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]


class JacobianPattern:
    """The blocks and the CSC pattern of the Jacobian of the model of ``plan``.

    Groups (G): ``group_dofs`` (G, 6) their coordinates in ``x`` (-1 padding),
    ``group_size`` (G,), ``group_body`` (G,) the moving-body slot or -1 for a free node.
    Nodes: ``node_group`` (n,) the group that moves each node or -1 (fixed);
    ``node_selection`` (n, 3, 6) a free node's ``dX/d(group coordinates)`` (zero for other
    nodes: a body node's ``[I, -hat(r)]`` depends on the state). Blocks (nk): ``block_rows``,
    ``block_cols`` (nk,) their groups, ``diagonal_block`` (G,) each group's own block,
    ``member_blocks`` (m, 4) the blocks of a member's ``(a, a), (a, b), (b, a), (b, b)``
    couplings (-1 where an end is fixed). CSC: ``indices``, ``indptr`` and ``source``: entry
    ``k`` of the data is entry ``source[k]`` of the flattened ``(T blocks (G, 6, 6), position
    blocks (nk, 6, 6), velocity blocks (nk, 6, 6))``.
    """

    def __init__(self, plan: Plan):
        n = plan.n_dof
        nodes = plan.n_nodes
        node_group = np.full(nodes, -1, dtype=np.int64)
        node_selection = np.zeros((nodes, 3, 6))
        groups: list[list[int]] = []
        body: list[int] = []
        for j in range(len(plan.free_node)):                 # free coordinates, node by node
            node = plan.free_node[j]
            if node_group[node] < 0:
                node_group[node] = len(groups)
                groups.append([])
                body.append(-1)
            g = node_group[node]
            node_selection[node, plan.free_axis[j], len(groups[g])] = 1.0
            groups[g].append(j)
        first_body_group = len(groups)
        for b, d in enumerate(plan.body_dof):
            groups.append(list(range(d, d + 6)))
            body.append(b)
        node_group[plan.on_node] = first_body_group + plan.on_body
        G = len(groups)
        self.group_size = np.array([len(g) for g in groups], dtype=np.int64)
        self.group_dofs = np.full((G, 6), -1, dtype=np.int64)
        for g, dofs in enumerate(groups):
            self.group_dofs[g, :len(dofs)] = dofs
        self.group_body = np.array(body, dtype=np.int64)
        self.node_group = node_group
        self.node_selection = node_selection

        ga, gb = node_group[plan.member_a], node_group[plan.member_b]
        pairs = {(g, g) for g in range(G)}
        joined = (ga >= 0) & (gb >= 0)
        pairs |= {(int(p), int(q)) for p, q in zip(ga[joined], gb[joined])}
        pairs |= {(int(q), int(p)) for p, q in zip(ga[joined], gb[joined])}
        ordered = sorted(pairs)
        index = {pq: k for k, pq in enumerate(ordered)}
        self.block_rows = np.array([p for p, _ in ordered], dtype=np.int64).reshape(-1)
        self.block_cols = np.array([q for _, q in ordered], dtype=np.int64).reshape(-1)
        self.diagonal_block = np.array([index[(g, g)] for g in range(G)], dtype=np.int64)
        member_blocks = np.full((len(ga), 4), -1, dtype=np.int64)
        for i, (p, q) in enumerate(zip(ga, gb)):
            for slot, key in enumerate(((p, p), (p, q), (q, p), (q, q))):
                if key[0] >= 0 and key[1] >= 0:
                    member_blocks[i, slot] = index[(int(key[0]), int(key[1]))]
        self.member_blocks = member_blocks

        # every stored entry: (row, column, flat source index); rows/columns in y = (x, v)
        rows, cols, source = [], [], []
        nk = len(ordered)
        six = np.arange(6)
        for g in range(G):                                   # T: d(dx/dt)/dv, diagonal blocks
            d = self.group_dofs[g, :self.group_size[g]]
            r, c = np.meshgrid(six[:len(d)], six[:len(d)], indexing="ij")
            rows.append(d[r].ravel())
            cols.append(n + d[c].ravel())
            source.append((g * 36 + r * 6 + c).ravel())
        for offset, col_shift in ((G * 36, 0), (G * 36 + nk * 36, n)):   # position, velocity blocks
            for k, (p, q) in enumerate(ordered):
                dp = self.group_dofs[p, :self.group_size[p]]
                dq = self.group_dofs[q, :self.group_size[q]]
                r, c = np.meshgrid(six[:len(dp)], six[:len(dq)], indexing="ij")
                rows.append(n + dp[r].ravel())
                cols.append(col_shift + dq[c].ravel())
                source.append((offset + k * 36 + r * 6 + c).ravel())
        R = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
        C = np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64)
        S = np.concatenate(source) if source else np.zeros(0, dtype=np.int64)
        order = np.lexsort((R, C))
        self.shape = (2 * n, 2 * n)
        self.indices = R[order].astype(np.int32)
        self.indptr = np.searchsorted(C[order], np.arange(2 * n + 1)).astype(np.int32)
        self.source = S[order].astype(np.int64)
        self.n_groups = G
        self.n_blocks = nk

    def matrix(self, data: FloatArray) -> sp.csc_matrix:
        """The CSC matrix of ``data`` (in this pattern's order), sharing the pattern's indices."""
        return sp.csc_matrix((data, self.indices, self.indptr), shape=self.shape)
