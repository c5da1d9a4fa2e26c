"""Member forces, potential energy, out-of-balance forces and the equilibrium matrix.

Sign conventions: member ``i`` runs from node ``a = members[i, 0]`` to node
``b = members[i, 1]``; ``h_i = n_b - n_a`` (Eq. 14), ``l_i = |h_i|``, unit vector
``u_i = h_i / l_i``. Member force ``t_i = EA_i (l_i - l0_i) / l0_i`` (Eq. 22), tension
positive; a string shorter than its rest length is slack (``t = 0``). A member in tension
pulls node ``a`` with ``+t u`` and node ``b`` with ``-t u``.

Total potential energy (Eqs. 46-53 with the sign of gravity made explicit)::

    V = sum_i EA_i (l_i - l0_i)^2 / (2 l0_i)   [taut members only]
        - sum_j f_j . n_j                       [dead loads incl. weights of point/member masses]
        - sum_b m_b g . c_b                     [rigid-body weights at the body centroids]

with ``g`` the gravity vector (e.g. ``[0, 0, -9.81]``). The out-of-balance (generalised)
force is ``P = -dV/dU``; for a free coordinate it is the net nodal force, for a rigid body
it is the net force and the net moment about the body centre (because ``U`` uses
rotation-vector increments at ``dtheta = 0``) -- i.e. exactly the physical residual.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, TypeAlias, overload

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.excerpt import excerpt
from tensegrity_core.general.configuration import Configuration, check_member_lengths, node_coordinates, node_jacobians
from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.schema import number_reason

#: Where a structure is: a :class:`Configuration`, node coordinates (n, 3) [m], or
#: ``None`` for the reference drawing.
StateLike: TypeAlias = Configuration | ArrayLike | None


def as_configuration(structure: Structure, state: StateLike) -> Configuration:
    """Accept a :class:`Configuration`, ``None`` (the reference drawing) or ``(n, 3)`` coordinates.

    Coordinates must be finite numbers (:func:`node_coordinates`) with no member of zero
    length (:func:`check_member_lengths`); else :class:`StructureError` naming ``coords``.

    A configuration of another structure with the same nodes and rigid bodies (e.g. before
    a change of rest lengths or loads) is re-bound to ``structure``.
    """
    if isinstance(state, Configuration):
        if state.structure is structure:
            return state
        old, new = state.structure.layout, structure.layout
        same = (state.structure.n_nodes == structure.n_nodes
                and np.array_equal(old.free_index, new.free_index)
                and np.array_equal(old.node_body, new.node_body)
                and np.allclose(old.offsets, new.offsets, rtol=0, atol=1e-12))
        if not same:
            raise StructureError("the configuration belongs to a structure with other nodes, "
                                 "supports or rigid bodies")
        return Configuration(structure, state.coords, state.centres, state.rotations)
    if state is None:
        return Configuration.initial(structure)
    config = Configuration.from_coords(structure, state)
    check_member_lengths(structure, config.coords)
    return config


def _coords(structure: Structure, state: StateLike) -> NDArray[np.float64]:
    if isinstance(state, Configuration):
        return state.coords
    if state is None:
        return structure.nodes
    return node_coordinates(structure, state, batch=True)


def member_vectors(structure: Structure, coords: ArrayLike) -> NDArray[np.float64]:
    """``h_i = n_b - n_a`` [m], shape ``(..., m, 3)`` for coords ``(..., n, 3)``."""
    xyz = np.asarray(coords, dtype=np.float64)
    h: NDArray[np.float64] = xyz[..., structure.members[:, 1], :] - xyz[..., structure.members[:, 0], :]
    return h


def member_lengths(structure: Structure, coords: StateLike) -> NDArray[np.float64]:
    """Member lengths [m], shape ``(..., m)`` for coords ``(..., n, 3)`` (batch dims allowed)."""
    lengths: NDArray[np.float64] = np.linalg.norm(member_vectors(structure, _coords(structure, coords)), axis=-1)
    return lengths


def forces_from_lengths(structure: Structure, lengths: ArrayLike,
                        rest_lengths: ArrayLike | None = None) -> NDArray[np.float64]:
    """Tension-positive member forces [N] for member lengths ``(..., m)`` [m]; strings go slack.

    ``rest_lengths`` [m] (default the structure's) must broadcast to ``(..., m)`` and be
    finite and positive, else :class:`StructureError` naming ``rest_lengths``.
    """
    lengths = np.asarray(lengths, dtype=float)
    l0 = structure.rest_lengths if rest_lengths is None else _rest_lengths(structure, rest_lengths, lengths.shape)
    t = structure.EA * (lengths - l0) / l0
    return np.where(structure.is_string & (t < 0.0), 0.0, t)


def _rest_lengths(structure: Structure, rest_lengths: ArrayLike, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """Checked override of the rest lengths [m] for member lengths of ``shape``."""
    try:
        l0 = np.asarray(rest_lengths, dtype=float)
        np.broadcast_shapes(l0.shape, shape)
    except (TypeError, ValueError):
        raise StructureError(f"rest_lengths must be numbers [m] of a shape that broadcasts to {shape} "
                             f"({structure.n_members} members), got {excerpt(rest_lengths)}",
                             entry=("rest_lengths",)) from None
    if not (np.isfinite(l0) & (l0 > 0.0)).all():
        raise StructureError(f"rest_lengths must be finite and positive [m], got {excerpt(l0.tolist())}",
                             entry=("rest_lengths",))
    return l0


def member_forces(structure: Structure, coords: StateLike, rest_lengths: ArrayLike | None = None) -> NDArray[np.float64]:
    """Tension-positive member forces [N], shape ``(..., m)``, for coords ``(..., n, 3)`` [m].

    ``rest_lengths`` overrides the structure's rest lengths (broadcastable to ``(..., m)``),
    for actuated simulations.
    """
    return forces_from_lengths(structure, member_lengths(structure, coords), rest_lengths)


def axial_stiffness(structure: Structure, lengths: ArrayLike) -> NDArray[np.float64]:
    """``dt/dl`` [N/m]: ``EA/l0`` for taut members, 0 for slack strings (``l < l0``; a string
    exactly at its rest length counts as taut, the stiffness it has when pulled)."""
    k = structure.EA / structure.rest_lengths
    slack = structure.is_string & (np.asarray(lengths) < structure.rest_lengths)
    return np.where(slack, 0.0, k)


def body_centres(structure: Structure, coords: ArrayLike) -> NDArray[np.float64]:
    """(nb, 3) centroids of the moving rigid bodies' nodes [m]."""
    lay = structure.layout
    xyz = np.asarray(coords, dtype=np.float64)
    centres: NDArray[np.float64] = group_sum(lay.body_slot, xyz[lay.on_body], len(lay.moving_bodies)) \
        / lay.body_sizes[:, None]
    return centres


def group_sum(index: NDArray[np.integer], values: ArrayLike, n: int) -> NDArray[np.float64]:
    """``out[k] = sum of values[i] with index[i] == k`` for (N, d) values: one ``bincount``
    over the bins ``(k, j)`` of the flattened values (much faster than ``np.add.at``; each bin
    sums its values in the order of ``i``, as a bincount per column would)."""
    v = np.asarray(values, dtype=np.float64)
    d = math.prod(v.shape[1:])
    bins = (np.asarray(index, dtype=np.int64)[:, None] * d + np.arange(d)).ravel()
    out = np.bincount(bins, weights=v.ravel(), minlength=n * d)
    return out.reshape((n,) + v.shape[1:])  # type: ignore[return-value]  # numpy's stubs: bincount with weights is typed intp, is float64


def potential_energy(structure: Structure, coords: StateLike) -> float:
    """Total potential energy ``V`` [J] (strain - work of dead loads and gravity)."""
    xyz = _coords(structure, coords)
    lengths = member_lengths(structure, xyz)
    stretch = lengths - structure.rest_lengths
    taut = ~(structure.is_string & (stretch < 0.0))
    strain = 0.5 * np.sum(np.where(taut, structure.EA * stretch**2 / structure.rest_lengths, 0.0))
    work = np.sum(structure.external_forces * xyz)
    lay = structure.layout
    if lay.body_masses.size:
        work += float(lay.body_masses @ (body_centres(structure, xyz) @ structure.gravity))
    return float(strain - work)


def internal_nodal_forces(structure: Structure, coords: ArrayLike,
                          forces: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """(n, 3) forces [N] that the members exert on the nodes."""
    xyz = np.asarray(coords, dtype=np.float64)
    h = member_vectors(structure, xyz)
    lengths = np.linalg.norm(h, axis=1)
    t = forces_from_lengths(structure, lengths) if forces is None else forces
    ft = (t / lengths)[:, None] * h
    return group_sum(structure.members.T.ravel(), np.concatenate([ft, -ft]), len(xyz))


def scatter_to_dofs(config: Configuration, node_vectors: ArrayLike) -> NDArray[np.float64]:
    """``G^T v`` for a nodal vector field ``v`` (n, 3): the generalised force of nodal forces
    (free coordinates take their component; a body takes the sum and the moment about its
    centre)."""
    lay = config.structure.layout
    v = np.asarray(node_vectors, dtype=float)
    out = np.zeros(lay.n_dof)
    out[lay.free_dofs] = v[lay.free_mask]
    nb = len(lay.moving_bodies)
    if nb:
        on = lay.on_body
        sums = group_sum(lay.body_slot, np.concatenate([v[on], cross(config.arms()[on], v[on])], axis=1), nb)
        out[lay.body_dofs] = sums
    return out


def cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``a x b`` row by row for (k, 3) arrays, the products and differences of ``np.cross``
    without its axis handling (which costs ~10 us a call, more than the sums of a small body)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


@dataclass
class OutOfBalance:
    """Out-of-balance forces of a configuration.

    ``generalized`` (n_dof,) is ``P = -dV/dU`` (forces [N] on free coordinates, then per
    moving body the net force [N] and the net moment about its centre [N m]);
    ``node_forces`` (n, 3) the net force on every node [N] (members + loads; on fixed
    coordinates it is minus the support reaction); ``body_forces``/``body_moments`` (nb, 3);
    ``force_residual`` the largest force component on a free coordinate or body [N];
    ``moment_residual`` the largest body moment component [N m]; ``residual`` [N] the
    larger of ``force_residual`` and every moment divided by its body's radius (largest
    node distance from the centre) -- the convergence measure of form-finding.
    """

    generalized: NDArray[np.float64]
    node_forces: NDArray[np.float64]
    body_forces: NDArray[np.float64]
    body_moments: NDArray[np.float64]
    force_residual: float
    moment_residual: float
    residual: float

    @property
    def reactions(self) -> NDArray[np.float64]:
        """(n, 3) support reactions [N] on fixed coordinates (zero elsewhere)."""
        return -self.node_forces


def generalized_force(structure: Structure, config: Configuration,
                      nodal_forces: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """``P = -dV/dU`` (n_dof,) at ``config``; ``nodal_forces`` (n, 3) if already computed."""
    lay = structure.layout
    f = internal_nodal_forces(structure, config.coords) + structure.external_forces \
        if nodal_forces is None else nodal_forces
    P = scatter_to_dofs(config, f)
    if lay.body_dof.size:
        P[lay.body_dofs[:, :3]] += lay.body_masses[:, None] * structure.gravity[None, :]
    return P


def out_of_balance(structure: Structure, coords: StateLike) -> OutOfBalance:
    """The physical residual at ``coords`` ((n, 3) array or :class:`Configuration`)."""
    config = as_configuration(structure, coords)
    lay = structure.layout
    f = internal_nodal_forces(structure, config.coords) + structure.external_forces
    P = generalized_force(structure, config, f)
    nb = len(lay.moving_bodies)
    if nb:
        cdofs = lay.body_dof[:, None] + np.arange(3)[None, :]
        body_forces = P[cdofs]
        body_moments = P[cdofs + 3]
    else:
        body_forces = body_moments = np.zeros((0, 3))
    free_f = P[: lay.n_free]
    force_res = float(max(np.abs(free_f).max(initial=0.0), np.abs(body_forces).max(initial=0.0)))
    moment_res = float(np.abs(body_moments).max(initial=0.0))
    eq = float((np.abs(body_moments) / lay.body_radii[:, None]).max(initial=0.0)) if nb else 0.0
    return OutOfBalance(P, f, body_forces, body_moments, force_res, moment_res,
                        max(force_res, eq))


@overload
def equilibrium_matrix(structure: Structure, coords: StateLike,
                       *, sparse: Literal[False] = False) -> NDArray[np.float64]: ...
@overload
def equilibrium_matrix(structure: Structure, coords: StateLike, *, sparse: Literal[True]) -> sp.csc_matrix: ...
@overload
def equilibrium_matrix(structure: Structure, coords: StateLike,
                       *, sparse: bool) -> NDArray[np.float64] | sp.csc_matrix: ...
def equilibrium_matrix(structure: Structure, coords: StateLike,
                       *, sparse: bool = False) -> NDArray[np.float64] | sp.csc_matrix:
    """``A_r = G^T A_2`` (n_dof, m), Eqs. 65-66: ``A_r t`` is the generalised force that
    member forces ``t`` take from the nodes, so equilibrium reads ``A_r t = G^T f_ext + w``
    (Eq. 64) and ``B_r = A_r^T`` is the compatibility matrix (``dl = B_r dU``, Eqs. 68-70).
    Dense ``ndarray`` unless ``sparse=True`` (CSC)."""
    config = as_configuration(structure, coords)
    lay = structure.layout
    J = node_jacobians(config)
    h = member_vectors(structure, config.coords)
    u = h / np.linalg.norm(h, axis=1)[:, None]
    a, b = structure.members[:, 0], structure.members[:, 1]
    m = structure.n_members
    vals = np.concatenate([np.einsum("mia,mi->ma", J[a], -u), np.einsum("mia,mi->ma", J[b], u)], axis=1)
    rows = np.concatenate([lay.node_dofs[a], lay.node_dofs[b]], axis=1)
    cols = np.repeat(np.arange(m)[:, None], 12, axis=1)
    keep = rows >= 0
    A = sp.csc_matrix((vals[keep], (rows[keep], cols[keep])), shape=(lay.n_dof, m))
    return A if sparse else A.toarray()


@dataclass
class Modes:
    """Singular value decomposition of the equilibrium matrix (Eq. 67).

    ``rank``; ``singular_values``; ``self_stress`` (m, s) orthonormal self-stress modes
    ``V2`` (a single mode is signed so its entries sum to >= 0, tension positive);
    ``mechanisms`` (n_dof, n_dof - rank) orthonormal mechanism modes ``W2`` (rigid-body
    motions included); ``tol`` the singular-value threshold used.
    """

    rank: int
    singular_values: NDArray[np.float64]
    self_stress: NDArray[np.float64]
    mechanisms: NDArray[np.float64]
    tol: float


def modes(structure: Structure, coords: StateLike = None, *, rtol: float = 1e-8) -> Modes:
    """Rank, self-stress and mechanism modes of ``A_r`` at ``coords`` (default: reference).

    Singular values below ``rtol`` times the largest count as zero (configurations from
    form-finding are exact to about 1e-10, data typed from a paper to its printed digits);
    ``0 <= rtol < 1``, else :class:`StructureError` naming ``rtol``.
    """
    _, why = number_reason(rtol, unit="", lo=0.0, hi=1.0, hi_open=True)
    if why:
        raise StructureError(f"rtol (relative singular-value threshold) {why}", entry=("rtol",))
    A = equilibrium_matrix(structure, coords)
    W, s, Vt = np.linalg.svd(A, full_matrices=True)
    tol = rtol * (s[0] if s.size else 0.0)
    r = int(np.sum(s > tol))
    V2 = Vt[r:].T.copy()
    if V2.shape[1] == 1 and V2.sum() < 0:
        V2 = -V2
    return Modes(r, s, V2, W[:, r:].copy(), tol)
