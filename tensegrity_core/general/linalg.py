"""Sparse positive-definiteness tests, shifted Newton solves and the stability eigenvalue.

Positive definiteness without an eigendecomposition: scipy has no sparse Cholesky, so a
symmetric matrix is factored by SuperLU with *no* off-diagonal pivoting
(``diag_pivot_thresh=0``, ``SymmetricMode``, the same fill-reducing ordering on rows and
columns). That is ``P A P^T = L D L^T`` with ``U = D L^T``; by Sylvester's law of inertia
``A`` is positive definite iff every pivot ``D_ii > 0`` and no pivot had to be taken off
the diagonal (which only happens at a zero pivot). This is the "Cholesky attempt";
adding an increasing multiple of the identity until it succeeds gives the shift of Eq. 81
within a factor of 4 (Nocedal & Wright, Alg. 3.3) at the cost of a few sparse
factorizations, instead of a full eigenvalue computation.

The stability eigenvalue is the smallest eigenvalue of ``K_T`` on the complement of the
zero-energy rigid-body motions. It is found by shift-invert Lanczos (``eigsh``) on
``K + alpha Z Z^T`` (rigid modes ``Z`` moved out of the way), with the shifted inverse
applied through the Woodbury identity on a sparse factorization of ``K + beta I``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, eigsh, splu

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.rotation import hat
from tensegrity_core.general.stiffness import sym_rotation_hessian

#: Scaled eigenvalues at or below this count as zero (unstiffened mechanism).
NEUTRAL_TOL = 1e-11


def jacobi_scaling(K) -> np.ndarray:
    """``d`` with ``diag(d) K diag(d)`` of unit diagonal (``d_i = |K_ii|^-1/2``; tiny or
    zero diagonals are floored at 1e-12 of the largest, so no entry blows up; all ones for a
    zero matrix)."""
    diag = np.abs(K.diagonal() if sp.issparse(K) else np.diag(K))
    top = diag.max(initial=0.0)
    if not top > 0:
        return np.ones_like(diag)
    return 1.0 / np.sqrt(np.maximum(diag, 1e-12 * top))


def factor_if_positive_definite(A):
    """SuperLU ``L D L^T`` factor of the sparse symmetric ``A`` if it is positive definite,
    else ``None`` (see the module docstring)."""
    A = sp.csc_matrix(A)
    try:
        lu = splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options=dict(SymmetricMode=True, Equil=False))
    except RuntimeError:          # exactly singular pivot: not positive definite
        return None
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    d = lu.U.diagonal()
    if not (np.all(d > 0) and np.all(np.isfinite(d))):
        return None
    return lu


@dataclass
class ShiftedStep:
    """A Newton direction from the shifted scaled stiffness (Eq. 81-82).

    ``dU`` the direction; ``shift`` the identity shift added to the Jacobi-scaled ``K_T``;
    ``min_eigenvalue`` of the scaled ``K_T`` when it was computed (dense path) else ``None``;
    ``factorizations`` how many factorizations were needed.
    """

    dU: np.ndarray
    shift: float
    min_eigenvalue: float | None
    factorizations: int


def shifted_step_dense(K, P, u: float) -> ShiftedStep:
    """The paper's procedure: full eigenvalues of the scaled ``K_T`` each step, Eq. 81 shift
    ``u + max(0, -lambda_min)``, dense Cholesky solve."""
    K = K.toarray() if sp.issparse(K) else np.asarray(K)
    d = jacobi_scaling(K)
    Ks = d[:, None] * K * d[None, :]
    lam = float(la.eigvalsh(Ks)[0])
    tau = u + max(0.0, -lam)
    c = la.cho_factor(Ks + tau * np.eye(len(d)))
    return ShiftedStep(d * la.cho_solve(c, d * P), tau, lam, 1)


def shifted_step_sparse(K, P, u: float, *, growth: float = 10.0, policy: str = "eq81") -> ShiftedStep:
    """Sparse Eq. 81 on the scaled ``K_T``.

    A Cholesky (``L D L^T``) attempt on ``K_s + u I`` decides definiteness. If it fails,
    shifts ``10 u, 100 u, ...`` are tried until one succeeds (``tau_ok``); then the
    smallest eigenvalue is the one nearest ``-tau_ok`` (all lie above it), found by
    shift-invert Lanczos with that very factor, and the shift is the paper's
    ``u + |lambda_min|`` (``policy="eq81"``) or ``tau_ok`` itself (``policy="bracket"``).
    """
    K = sp.csr_matrix(K)
    d = jacobi_scaling(K)
    D = sp.diags(d)
    Ks = (D @ K @ D).tocsc()
    n = K.shape[0]
    eye = sp.identity(n, format="csc")
    lu = factor_if_positive_definite(Ks + u * eye)
    if lu is not None:
        return ShiftedStep(d * lu.solve(d * P), u, None, 1)
    tau, tries = u, 1
    while lu is None:
        if tries > 40:
            raise FloatingPointError("no positive shift makes the scaled stiffness positive definite")
        tau *= growth
        tries += 1
        lu = factor_if_positive_definite(Ks + tau * eye)
    lam = None
    if policy == "eq81":
        OPinv = LinearOperator((n, n), matvec=lambda x: lu.solve(np.asarray(x, dtype=float).ravel()),
                               dtype=float)
        v0 = np.random.default_rng(0).standard_normal(n)
        lam = float(eigsh(Ks, k=1, sigma=-tau, which="LM", OPinv=OPinv, v0=v0, tol=1e-6,
                          return_eigenvectors=False)[0])
        shift = u + max(0.0, -lam)
        lu2 = factor_if_positive_definite(Ks + shift * eye)
        tries += 1
        if lu2 is not None:
            lu, tau = lu2, shift
    return ShiftedStep(d * lu.solve(d * P), tau, lam, tries)


def rigid_motions(config: Configuration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Infinitesimal rigid motions of the whole structure in ``U``.

    Returns ``T`` (n_dof, 6): columns are translations x, y, z and rotations about x, y, z
    through the centroid ``o`` of all nodes; ``F`` (n_fixed, 6): the motion each would
    impose on the fixed coordinates; ``o``.
    """
    s = config.structure
    lay = s.layout
    o = config.coords.mean(axis=0)
    E = np.eye(3)
    node_motion = np.zeros((s.n_nodes, 3, 6))        # displacement of node i, axis j, motion k
    node_motion[:, :, :3] = E[None]
    node_motion[:, :, 3:] = -hat(config.coords - o)     # e_k x d = -hat(d) e_k
    T = np.zeros((lay.n_dof, 6))
    free = lay.free_index >= 0
    T[lay.free_index[free]] = node_motion[free]
    if lay.body_dof.size:
        rows = lay.body_dof[:, None] + np.arange(3)[None, :]
        T[rows.ravel(), :3] = np.tile(E, (len(lay.body_dof), 1))
        T[rows.ravel(), 3:] = (-hat(config.centres - o)).reshape(-1, 3)
        T[(rows + 3).ravel(), 3:] = np.tile(E, (len(lay.body_dof), 1))
    F = node_motion[lay.fixed_mask]
    return T, F, o


def zero_energy_rigid_modes(config: Configuration) -> np.ndarray:
    """Orthonormal basis (n_dof, k) of the rigid-body motions that the supports allow and
    along which the potential is stationary to second order at an equilibrium.

    Translations always qualify (when allowed); rotations qualify unless dead loads or
    weights make the potential change to second order along them (load stiffness), in
    which case they are part of the stability question and are kept.
    """
    s = config.structure
    T, F, o = rigid_motions(config)
    N = la.null_space(F) if F.shape[0] else np.eye(6)
    if N.shape[1] == 0:
        return np.zeros((T.shape[0], 0))
    f = s.external_forces
    lay = s.layout
    HL = np.zeros((6, 6))
    HL[3:, 3:] = sym_rotation_hessian(-f, config.coords - o).sum(axis=0)
    w = lay.body_masses[:, None] * s.gravity[None, :]
    if w.size:
        HL[3:, 3:] += sym_rotation_hessian(-w, config.centres - o).sum(axis=0)
    scale = float(np.sum(np.linalg.norm(f, axis=1) * np.linalg.norm(config.coords - o, axis=1)))
    if w.size:
        scale += float(np.sum(np.linalg.norm(w, axis=1) * np.linalg.norm(config.centres - o, axis=1)))
    Hn = N.T @ HL @ N
    mu, Y = np.linalg.eigh(0.5 * (Hn + Hn.T))
    keep = np.abs(mu) <= 1e-10 * scale if scale > 0 else np.ones(len(mu), dtype=bool)
    if not keep.any():
        return np.zeros((T.shape[0], 0))
    Z = T @ (N @ Y[:, keep])
    q, r = np.linalg.qr(Z)
    rank = int(np.sum(np.abs(np.diag(r)) > 1e-12 * max(np.abs(r).max(), 1e-300)))
    return q[:, :rank]


@dataclass
class LowestMode:
    """Smallest eigenvalue of ``K_T`` on the complement of the excluded rigid-body modes,
    physical (``value``, mixed units of ``U``) and of the Jacobi-scaled matrix (``scaled``,
    dimensionless, decides stability), with the scaled mode mapped back to ``U``
    (``vector``) and the number of excluded rigid-body modes."""

    value: float
    scaled: float
    vector: np.ndarray
    rigid_body_modes: int


def _complement_lowest_dense(K: np.ndarray, Z: np.ndarray) -> tuple[float, np.ndarray]:
    n = K.shape[0]
    if Z.shape[1] == 0:
        w, V = la.eigh(K, subset_by_index=[0, 0])
        return float(w[0]), V[:, 0]
    C = la.null_space(Z.T)
    if C.shape[1] == 0:
        return float("inf"), np.zeros(n)
    w, V = la.eigh(C.T @ K @ C, subset_by_index=[0, 0])
    return float(w[0]), C @ V[:, 0]


def _complement_lowest_sparse(K, Z: np.ndarray) -> tuple[float, np.ndarray]:
    """Shift-invert Lanczos on ``K + alpha Z Z^T`` (Woodbury inverse of a sparse factor)."""
    K = sp.csc_matrix(K)
    n = K.shape[0]
    alpha = 2.0 * float(abs(K).sum(axis=1).max()) + 1.0     # above every eigenvalue of K
    eye = sp.identity(n, format="csc")
    beta = 1e-9 * float(np.abs(K.diagonal()).max(initial=1.0))
    for _ in range(80):
        lu = factor_if_positive_definite(K + beta * eye)
        if lu is not None:
            break
        beta *= 4.0
    else:   # pragma: no cover - Gershgorin guarantees success long before
        raise FloatingPointError("could not bracket the smallest eigenvalue")
    k = Z.shape[1]
    if k:
        MZ = lu.solve(Z)
        small = np.linalg.inv(np.eye(k) / alpha + Z.T @ MZ)

        def solve(x):
            y = lu.solve(np.asarray(x, dtype=float).ravel())
            return y - MZ @ (small @ (Z.T @ y))
    else:
        def solve(x):
            return lu.solve(np.asarray(x, dtype=float).ravel())

    def matvec(x):
        x = np.asarray(x, dtype=float).ravel()
        return K @ x + (alpha * (Z @ (Z.T @ x)) if k else 0.0)

    A = LinearOperator((n, n), matvec=matvec, dtype=float)
    OPinv = LinearOperator((n, n), matvec=solve, dtype=float)
    v0 = np.random.default_rng(0).standard_normal(n)
    w, V = eigsh(A, k=1, sigma=-beta, which="LM", OPinv=OPinv, v0=v0, tol=1e-10)
    return float(w[0]), V[:, 0]


def lowest_mode(K, config: Configuration, *, dense: bool) -> LowestMode:
    """The stability eigenvalue of ``K_T`` at an equilibrium ``config`` (see :class:`LowestMode`)."""
    Z = zero_energy_rigid_modes(config)
    d = jacobi_scaling(K)
    if dense:
        Kd = K.toarray() if sp.issparse(K) else np.asarray(K)
        value, _ = _complement_lowest_dense(Kd, Z)
        Zs = _orthonormal(Z / d[:, None])
        scaled, vs = _complement_lowest_dense(d[:, None] * Kd * d[None, :], Zs)
    else:
        K = sp.csr_matrix(K)
        value, _ = _complement_lowest_sparse(K, Z)
        D = sp.diags(d)
        Zs = _orthonormal(Z / d[:, None])
        scaled, vs = _complement_lowest_sparse(D @ K @ D, Zs)
    return LowestMode(value, scaled, d * vs, Z.shape[1])


def _orthonormal(Z: np.ndarray) -> np.ndarray:
    if Z.shape[1] == 0:
        return Z
    q, _ = np.linalg.qr(Z)
    return q
