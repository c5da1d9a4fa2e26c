"""The convergence measure of form-finding: out-of-balance forces against the forces that meet.

A free node is balanced when the net force on it is small *compared with the forces that
meet there*, whatever the stiffest member of the structure is. For every free node ``j``
(not on a moving rigid body, at least one axis free) and every moving rigid body ``b``:

- ``imbalance``: the Euclidean norm of the net force on the free axes of ``j`` [N]; for a
  body the norm of its net force [N] and, as a second row, of its net moment about its
  centre [N m] (the entries of ``P = -dV/dU``);
- ``scale``, the forces that meet there: ``S_j = sum |t_i| + |f_j|`` over the members at
  ``j`` (tension or compression) and the dead load on it [N]; a body's force row has
  ``S_b = sum_j S_j + m_b |g|`` over its nodes, its moment row ``sum_j |r_j| S_j`` [N m]
  with ``r_j`` the arm of node ``j`` from the body's centre: the most those forces could
  push or turn it. By the triangle inequality ``imbalance <= scale``, so the relative
  residual ``imbalance / scale`` is 0 for a balanced node and 1 for a node pulled by one
  member alone;
- ``floor``, the rounding level of the imbalance [N, N m]: the coordinates of an iterate are
  doubles, so a member's length is only known to ``eps (|x_a| + |x_b|)`` (the distances of its
  ends from the origin) and its force to ``EA/l0`` times that; with the rounding of the
  forces themselves, ``rho_j = eps sum_i (EA_i/l0_i (|x_a| + |x_b|) + |t_i|) + eps |f_j|``
  over taut members; a body sums its nodes' (moments: times their arms, plus ``eps (|c| +
  radius) S_b`` for the rounding of the arms). No iterate can balance a node much better.

``residual`` is the largest ``imbalance / scale`` (dimensionless); form-finding has
converged when every row has ``imbalance <= tol scale + FLOOR_FACTOR floor``: balanced to
the tolerance, or as well as double precision can tell (a node next to very stiff or very
short members far from the origin; the result then says so). ``residual_norm`` is the
Euclidean norm of ``P`` [N, N m], the absolute measure other tools report.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.statics import (
    OutOfBalance,
    axial_stiffness,
    forces_from_lengths,
    member_lengths,
    out_of_balance,
)
from tensegrity_core.general.structure import Structure

FloatArray = NDArray[np.float64]

#: Default tolerance on the relative residual (dimensionless; docs/general.md).
DEFAULT_TOLERANCE: Final = 1e-10
#: Multiple of the rounding level ``floor`` up to which a row counts as balanced
#: (measured: Newton ends at 0.1-2 times ``floor`` on stiff, short and far members).
FLOOR_FACTOR: Final = 4.0
_EPS: Final = float(np.finfo(float).eps)


@dataclass(frozen=True)
class Balance:
    """The out-of-balance of a configuration, row by row (free nodes, then each moving body's
    force and moment), against the forces that meet there (see the module docstring).

    ``physical`` the :class:`~tensegrity_core.general.statics.OutOfBalance` it was made from;
    ``imbalance``, ``scale``, ``floor`` (r,) [N or N m]; ``free_nodes`` the node of each of the
    first rows, ``node_names`` and ``body_names`` the structure's (see :meth:`row_name`).
    """

    physical: OutOfBalance
    imbalance: FloatArray
    scale: FloatArray
    floor: FloatArray
    free_nodes: NDArray[np.int64]
    node_names: tuple[str, ...]
    body_names: tuple[str, ...]

    def row_name(self, row: int) -> str:
        """The node or body of a row, e.g. ``"node 'n3'"``, ``"rigid body 'top' (moment)"``."""
        k = len(self.free_nodes)
        if row < k:
            return f"node {self.node_names[int(self.free_nodes[row])]!r}"
        nb = len(self.body_names)
        body = self.body_names[(row - k) % nb]
        return f"rigid body {body!r}" + (" (moment)" if row - k >= nb else "")

    @property
    def relative(self) -> FloatArray:
        """(r,) ``imbalance / scale`` (0 where nothing meets: then nothing is out of balance)."""
        return np.divide(self.imbalance, self.scale, out=np.zeros_like(self.imbalance), where=self.scale > 0)

    @property
    def residual(self) -> float:
        """The largest relative imbalance (dimensionless; 0 balanced, 1 one member alone)."""
        return float(self.relative.max(initial=0.0))

    @property
    def residual_norm(self) -> float:
        """Euclidean norm of all out-of-balance forces and moments [N, N m]."""
        return float(np.linalg.norm(self.physical.generalized))

    def converged(self, tol: float) -> bool:
        """Every row balanced to ``tol`` of its forces or to its rounding level."""
        return bool(np.all(self.imbalance <= tol * self.scale + FLOOR_FACTOR * self.floor))

    def at_rounding_level(self, tol: float) -> int | None:
        """The row above ``tol`` with the largest relative residual (after convergence: one
        balanced only to its rounding level), or None when every row is within ``tol``."""
        above = self.imbalance > tol * self.scale
        if not above.any():
            return None
        return int(np.argmax(np.where(above, self.relative, -1.0)))

    def row_nodes(self, row: int, structure: Structure) -> NDArray[np.int64]:
        """The node of a node row, the nodes of a body's rows."""
        k = len(self.free_nodes)
        if row < k:
            return self.free_nodes[row:row + 1]
        return np.asarray(structure.layout.body_nodes[(row - k) % len(self.body_names)], dtype=np.int64)


def balance(structure: Structure, config: Configuration) -> Balance:
    """The :class:`Balance` of ``structure`` at ``config``."""
    physical = out_of_balance(structure, config)
    lay = structure.layout
    x = config.coords
    a, b = structure.members[:, 0], structure.members[:, 1]
    n = structure.n_nodes
    lengths = member_lengths(structure, x)
    t = np.abs(forces_from_lengths(structure, lengths))
    reach = np.linalg.norm(x, axis=1)
    member_floor = _EPS * (axial_stiffness(structure, lengths) * (reach[a] + reach[b]) + t)
    load = np.linalg.norm(structure.external_forces, axis=1)
    node_scale = np.bincount(a, t, n) + np.bincount(b, t, n) + load
    node_floor = np.bincount(a, member_floor, n) + np.bincount(b, member_floor, n) + _EPS * load

    free_axes = lay.free_index >= 0
    free = np.flatnonzero((lay.node_body < 0) & free_axes.any(axis=1))
    imbalance = [np.linalg.norm(np.where(free_axes[free], physical.node_forces[free], 0.0), axis=1)]
    scale, floor = [node_scale[free]], [node_floor[free]]
    nb = len(lay.moving_bodies)
    if nb:
        on = np.flatnonzero(lay.node_body >= 0)
        slot = lay.node_body[on]
        arm = np.linalg.norm(config.arms()[on], axis=1)
        weight = lay.body_masses * float(np.linalg.norm(structure.gravity))
        body_scale = np.bincount(slot, node_scale[on], nb) + weight
        reach_c = np.linalg.norm(config.centres, axis=1) + lay.body_radii
        imbalance += [np.linalg.norm(physical.body_forces, axis=1), np.linalg.norm(physical.body_moments, axis=1)]
        scale += [body_scale, np.bincount(slot, arm * node_scale[on], nb)]
        floor += [np.bincount(slot, node_floor[on], nb) + _EPS * weight,
                  np.bincount(slot, arm * node_floor[on], nb) + _EPS * reach_c * body_scale]
    return Balance(physical, np.concatenate(imbalance), np.concatenate(scale), np.concatenate(floor),
                   free, structure.node_names, lay.body_names)
