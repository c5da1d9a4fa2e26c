"""The index arrays and matrices of a model's flat RK4 buffers (:mod:`.flat_stages`).

:class:`FlatLayout` holds, for a plan without moving bodies, the gathers of the flat buffer
(both ends of every member, every free coordinate's terms in member order) and, when the
state moves whole nodes (:func:`whole_nodes`), the node-major matrices: the members' signed
incidence over the nodes and its transpose scaled by the masses' inverses. The plans of one
model's slack sets share it (their topology, masses and loads are the same).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels.plan import Plan

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def whole_nodes(plan: Plan) -> IntArray | None:
    """The nodes whose coordinates the state of ``plan`` moves, in the state's order, if it
    moves each one's three coordinates in turn (x, y, z) with one mass; else None."""
    node, axis = plan.free_node, plan.free_axis
    if len(node) % 3:
        return None
    triples, inverse_mass = node.reshape(-1, 3), plan.free_inv_mass.reshape(-1, 3)
    whole = (np.array_equal(axis, np.tile(np.arange(3), len(triples))) and bool(np.all(triples == triples[:, :1]))
             and bool(np.all(inverse_mass == inverse_mass[:, :1])))
    return np.ascontiguousarray(triples[:, 0]) if whole else None


class FlatLayout:
    """The index arrays and matrices of the flat buffers of ``plan`` (:mod:`.flat_stages`).

    Gathers: sources ``S[:sources]``: ``y``, the drawn coordinates, the external forces on the
    free coordinates, a zero. ``ends`` (2, 3, m): per member end (a, b), component and member,
    the entry of the sources giving that node coordinate (a free one its ``x``, a fixed one its
    drawn value); ``velocity_ends`` likewise for velocities (a fixed coordinate: the zero).
    ``terms`` (d, N): per entry of ``dy/dt`` the entries it sums, padded with the zero: for
    ``x`` its ``v``; for ``v`` its external force, then per member in member order the
    member's force on it, an entry of the (2, 3, m) block ``[+force on a | -force on b]``
    right after the sources; ``scale`` (N,) the factor of each sum (1 for ``x``, the
    inverse mass for ``v``).

    Node-major maps (:meth:`node_maps`), if the state moves whole nodes (:func:`whole_nodes`):
    ``moving`` the moving nodes in the state's order, ``fixed`` the others."""

    def __init__(self, plan: Plan):
        n, m, n_free = plan.n_nodes, len(plan.member_a), len(plan.free_node)
        N = 2 * n_free
        self.n_state, self.n_members, self.n_free = N, m, n_free
        external = N + 3 * n
        self.zero = external + n_free
        self.sources = self.zero + 1
        position = N + 3 * np.arange(n)[:, None] + np.arange(3)
        velocity = np.full((n, 3), self.zero, dtype=np.int64)
        position[plan.free_node, plan.free_axis] = np.arange(n_free)
        velocity[plan.free_node, plan.free_axis] = n_free + np.arange(n_free)
        a, b = plan.member_a, plan.member_b
        self.ends = np.ascontiguousarray(np.stack([position[a].T, position[b].T]), dtype=np.int64)
        self.velocity_ends = np.ascontiguousarray(np.stack([velocity[a].T, velocity[b].T]), dtype=np.int64)
        tail = self.sources
        coordinate = np.full((n, 3), -1, dtype=np.int64)
        coordinate[plan.free_node, plan.free_axis] = np.arange(n_free)
        lists: list[list[int]] = [[external + j] for j in range(n_free)]
        for i in range(m):                        # member order, as the loops add the forces
            for k in range(3):
                for node, side in ((a[i], 0), (b[i], 1)):
                    j = coordinate[node, k]
                    if j >= 0:
                        lists[j].append(tail + side * 3 * m + k * m + i)
        self.terms = np.full((max([1] + [len(t) for t in lists]), N), self.zero, dtype=np.int64)
        self.terms[0, :n_free] = n_free + np.arange(n_free)
        for j, t in enumerate(lists):
            self.terms[:len(t), n_free + j] = t
        self.scale = np.concatenate([np.ones(n_free), plan.free_inv_mass])
        self.constants = np.concatenate([np.asarray(plan.base, dtype=float).ravel(),
                                         plan.external[plan.free_node, plan.free_axis], [0.0]])

        self.moving = whole_nodes(plan)
        self.fixed = None if self.moving is None else np.setdiff1d(np.arange(n), self.moving)
        self._plan = plan

    @cached_property
    def _node_maps(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        assert self.moving is not None and self.fixed is not None, "node-major maps need whole moving nodes"
        plan, moving, fixed = self._plan, self.moving, self.fixed
        nf, m = len(fixed), self.n_members
        row = np.empty(plan.n_nodes, dtype=np.int64)
        row[fixed], row[moving] = np.arange(nf), nf + np.arange(len(moving))
        C = np.zeros((m, plan.n_nodes))
        members = np.arange(m)
        np.add.at(C, (members, row[plan.member_b]), 1.0)
        np.add.at(C, (members, row[plan.member_a]), -1.0)
        inverse_mass = plan.free_inv_mass[::3]
        moving_part = np.ascontiguousarray(C[:, nf:])
        pull = -inverse_mass[:, None] * moving_part.T
        return (C, moving_part, np.ascontiguousarray(pull), inverse_mass,
                np.asarray(plan.base, dtype=float)[fixed], np.asarray(plan.external, dtype=float)[moving])

    def node_maps(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """(built on first use, kept: do not modify) ``(C, C_moving, pull, inverse_mass,
        x_fixed, external)``: the members' signed incidence ``C`` (m, n) over the rows ``[fixed
        | moving]`` (``h = C x``), its moving columns (``dv = C_moving v``), ``pull`` (n_moving,
        m) the acceleration of each moving node per unit force of a member on its node ``a``
        (``-C_moving^T / mass``), the moving nodes' inverse masses [1/kg], the fixed nodes'
        positions (n - n_moving, 3) [m] and the external forces on the moving nodes
        (n_moving, 3) [N]."""
        return self._node_maps

    def dense_entries(self) -> int:
        """Entries of the node-major matrices: the incidence (m, n) and the rate matrix
        (2 n_moving, 2 n_moving + 3m); 0 without moving nodes."""
        moving = 0 if self.moving is None else len(self.moving)
        return self.n_members * self._plan.n_nodes + 2 * moving * (2 * moving + 3 * self.n_members)
