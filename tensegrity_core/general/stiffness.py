"""The exact tangent stiffness ``K_T = d^2 V / dU^2`` (dense or sparse) and modal analysis.

With the rotation-vector increment at ``dtheta = 0`` (see :mod:`.configuration`), a body
node is ``n_j = c + exp(hat(dtheta)) r_j``, whose second derivative contracted with a
vector ``g`` is the *symmetric* matrix::

    d^2 (g . n_j) / d dtheta^2 = 1/2 (hat(g) hat(r_j) + hat(r_j) hat(g))
                               = 1/2 (g r_j^T + r_j g^T) - (g . r_j) I.

Hence, with ``g_j = dV/dn_j`` split into member and load parts::

    K_T = K_E + K_G + K_L
    K_E = G^T [sum_i k_i (C_i^T C_i) (x) u_i u_i^T] G          = A_r diag(k) A_r^T   (Eq. 72)
    K_G = G^T [sum_i t_i/l_i (C_i^T C_i) (x) (I - u_i u_i^T)] G
          + sum_bodies sum_j S(-f_int,j, r_j)                   (members' forces)
    K_L = sum_bodies sum_j S(-f_ext,j, r_j)                     (dead loads on body nodes)

where ``S(g, r) = 1/2 (g r^T + r g^T) - (g . r) I`` sits in the body's rotation block,
``k_i = EA_i / l0_i`` for taut members and 0 for slack strings, and ``t_i`` is the member
force. The paper's K_G (Eqs. 73-80) has ``hat(z) hat(r)`` in place of ``S`` (not
symmetric; equal to ``S`` only where the body moment of the member forces vanishes) and
no ``K_L``. ``K_T`` is the exact Jacobian of ``-P`` with respect to the increment ``dU``
at any configuration, in or out of equilibrium, with or without loads (tests check it
against finite differences).
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral
from typing import Literal, overload

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.errors import ParameterError
from tensegrity_core.general.configuration import Configuration, node_jacobians, transformation_matrix
from tensegrity_core.general.statics import (
    StateLike,
    as_configuration,
    axial_stiffness,
    forces_from_lengths,
    group_sum,
    internal_nodal_forces,
    member_vectors,
)
from tensegrity_core.general.structure import Structure


def sym_rotation_hessian(g: ArrayLike, r: ArrayLike) -> NDArray[np.float64]:
    """``S(g, r) = 1/2 (g r^T + r g^T) - (g . r) I``, vectorised over leading dims."""
    ga = np.asarray(g, dtype=np.float64)
    ra = np.asarray(r, dtype=np.float64)
    outer = 0.5 * (ga[..., :, None] * ra[..., None, :] + ra[..., :, None] * ga[..., None, :])
    S: NDArray[np.float64] = outer - np.sum(ga * ra, axis=-1)[..., None, None] * np.eye(3)
    return S


@dataclass
class _MemberState:
    J: NDArray[np.float64]        # (n, 3, 6) node Jacobians
    uu: NDArray[np.float64]       # (m, 3, 3) u u^T
    lengths: NDArray[np.float64]  # (m,)
    k: NDArray[np.float64]        # (m,) dt/dl
    t: NDArray[np.float64]        # (m,) forces


def _member_state(structure: Structure, config: Configuration, slack_elastic: bool = False) -> _MemberState:
    h = member_vectors(structure, config.coords)
    lengths = np.linalg.norm(h, axis=1)
    u = h / lengths[:, None]
    k = structure.EA / structure.rest_lengths if slack_elastic else axial_stiffness(structure, lengths)
    return _MemberState(node_jacobians(config), u[:, :, None] * u[:, None, :], lengths,
                        k, forces_from_lengths(structure, lengths))


def _element_matrices(config: Configuration, node_blocks: NDArray[np.float64],
                      J: NDArray[np.float64]) -> NDArray[np.float64]:
    """(m, 12, 12) ``J_e^T [[k, -k], [-k, k]] J_e`` for node-space member blocks ``k`` (m, 3, 3)."""
    s = config.structure
    Ja, Jb = J[s.members[:, 0]], J[s.members[:, 1]]
    kJa = node_blocks @ Ja                       # (m, 3, 6)
    kJb = node_blocks @ Jb
    Jat, Jbt = np.swapaxes(Ja, 1, 2), np.swapaxes(Jb, 1, 2)
    out = np.empty((len(node_blocks), 12, 12))
    out[:, :6, :6] = Jat @ kJa
    out[:, :6, 6:] = -(Jat @ kJb)
    out[:, 6:, :6] = -(Jbt @ kJa)
    out[:, 6:, 6:] = Jbt @ kJb
    return out


def _body_blocks(config: Configuration, node_gradient: NDArray[np.float64]) -> NDArray[np.float64]:
    """(nb, 3, 3) rotation blocks ``sum_j S(g_j, r_j)`` for a nodal gradient field ``g``."""
    lay = config.structure.layout
    nb = len(lay.moving_bodies)
    on = lay.node_body >= 0
    if not (nb and on.any()):
        return np.zeros((nb, 3, 3))
    return group_sum(lay.node_body[on], sym_rotation_hessian(node_gradient[on], config.arms()[on]), nb)


@overload
def stiffness_parts(structure: Structure, coords: StateLike,
                    *, sparse: Literal[False] = False) -> dict[str, NDArray[np.float64]]: ...
@overload
def stiffness_parts(structure: Structure, coords: StateLike, *, sparse: Literal[True]) -> dict[str, sp.csr_matrix]: ...
@overload
def stiffness_parts(structure: Structure, coords: StateLike,
                    *, sparse: bool) -> dict[str, NDArray[np.float64]] | dict[str, sp.csr_matrix]: ...
def stiffness_parts(structure: Structure, coords: StateLike,
                    *, sparse: bool = False) -> dict[str, NDArray[np.float64]] | dict[str, sp.csr_matrix]:
    """``{"KE", "KG", "KL"}``: material, geometric (members' forces, exact) and load stiffness.

    ``K_T = KE + KG + KL``; see the module docstring. Dense unless ``sparse=True`` (CSR).
    """
    config = as_configuration(structure, coords)
    pat = structure.stiffness_pattern
    ms = _member_state(structure, config)
    nb = len(structure.layout.moving_bodies)
    KE = pat.assemble(_element_matrices(config, ms.k[:, None, None] * ms.uu, ms.J), np.zeros((nb, 3, 3)))
    geo = (ms.t / ms.lengths)[:, None, None] * (np.eye(3) - ms.uu)
    f_int = internal_nodal_forces(structure, config.coords, ms.t)
    KG = pat.assemble(_element_matrices(config, geo, ms.J), _body_blocks(config, -f_int))
    KL = pat.assemble(np.zeros((structure.n_members, 12, 12)),
                      _body_blocks(config, -structure.external_forces))
    parts = {"KE": KE, "KG": KG, "KL": KL}
    return parts if sparse else {key: M.toarray() for key, M in parts.items()}


@overload
def tangent_stiffness(structure: Structure, coords: StateLike, *, sparse: Literal[False] = False,
                      slack_elastic: bool = False) -> NDArray[np.float64]: ...
@overload
def tangent_stiffness(structure: Structure, coords: StateLike, *, sparse: Literal[True],
                      slack_elastic: bool = False) -> sp.csr_matrix: ...
@overload
def tangent_stiffness(structure: Structure, coords: StateLike, *, sparse: bool,
                      slack_elastic: bool = False) -> NDArray[np.float64] | sp.csr_matrix: ...
def tangent_stiffness(structure: Structure, coords: StateLike, *, sparse: bool = False,
                      slack_elastic: bool = False) -> NDArray[np.float64] | sp.csr_matrix:
    """Exact tangent stiffness ``K_T = d^2V/dU^2`` (n_dof, n_dof) at ``coords``.

    ``coords`` is an (n, 3) array [m], a :class:`Configuration` or ``None`` (reference).
    Units follow ``U``: N/m between translations, N (= N m/m) between a translation and a
    rotation, N m/rad between rotations. Dense ``ndarray`` unless ``sparse=True`` (CSR).

    ``slack_elastic=True`` gives slack strings their elastic stiffness ``EA/l0`` (as if they
    could push): not the Hessian of ``V`` where a string is slack, but a better-conditioned
    Newton matrix while strings are slack (see :func:`~.formfind.newton`).
    """
    config = as_configuration(structure, coords)
    ms = _member_state(structure, config, slack_elastic)
    blocks = ms.k[:, None, None] * ms.uu + (ms.t / ms.lengths)[:, None, None] * (np.eye(3) - ms.uu)
    g = -(internal_nodal_forces(structure, config.coords, ms.t) + structure.external_forces)
    K = structure.stiffness_pattern.assemble(_element_matrices(config, blocks, ms.J), _body_blocks(config, g))
    return K if sparse else K.toarray()


@dataclass
class ModalAnalysis:
    """Eigenvalues (ascending) and mode shapes of ``K_T``.

    ``eigenvalues`` (k,) in the mixed units of ``U`` (see :func:`tangent_stiffness`);
    ``modes`` (n_dof, k) orthonormal eigenvectors in ``U``; ``displacements`` (k, n, 3)
    the nodal displacement field ``G phi`` of each mode (first order); ``labels`` the
    names of the entries of ``U``.
    """

    eigenvalues: NDArray[np.float64]
    modes: NDArray[np.float64]
    displacements: NDArray[np.float64]
    labels: list[str]


def modal_analysis(structure: Structure, coords: StateLike = None, *, n_modes: int | None = None) -> ModalAnalysis:
    """Eigen-decomposition of the exact ``K_T`` at ``coords`` (default: reference drawing).

    ``n_modes`` (a whole number >= 1, or None for all) limits the result to the lowest
    ``min(n_modes, n_dof)`` modes; anything else raises
    :class:`~tensegrity_core.errors.ParameterError`. Note that eigenvalues of a matrix mixing
    N/m and N m/rad depend on the length unit; compare modes of the same kind.
    """
    from scipy.linalg import eigh

    asked: object = n_modes                  # callers outside the type checker pass anything
    if asked is not None and (isinstance(asked, bool) or not isinstance(asked, Integral) or int(asked) < 1):
        raise ParameterError(f"n_modes must be a whole number >= 1 (or None for every mode), got {asked!r}")
    config = as_configuration(structure, coords)
    K = tangent_stiffness(structure, config)
    n = K.shape[0]
    k = n if n_modes is None else min(int(n_modes), n)
    w, V = eigh(K, subset_by_index=[0, k - 1])
    G = transformation_matrix(config)
    disp = (G @ V).T.reshape(k, structure.n_nodes, 3)
    return ModalAnalysis(w, V, disp, structure.layout.labels())
