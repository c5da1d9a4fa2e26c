"""Sparse positive-definiteness tests, the rounding level of a stiffness matrix, shifted
Newton solves and the rigid-body motions excluded from both.

Positive definiteness without an eigendecomposition: scipy has no sparse Cholesky, so a
symmetric matrix is factored by SuperLU with *no* off-diagonal pivoting
(``diag_pivot_thresh=0``, ``SymmetricMode``, the same fill-reducing ordering on rows and
columns). That is ``P A P^T = L D L^T`` with ``U = D L^T``; by Sylvester's law of inertia
``A`` is positive definite iff every pivot ``D_ii > 0`` and no pivot had to be taken off
the diagonal (which only happens at a zero pivot). This is the "Cholesky attempt".

Newton's matrix is the Jacobi-scaled ``K_s = D K_T D`` (unit diagonal). Its **rounding
level** ``rho = N eps ||K_s||_inf`` (:func:`rounding_level`, ``N`` the most nonzeros in a
row) bounds what the rounding of the assembly does to its eigenvalues: an entry is a sum
of at most ``N`` element contributions, so ``|dK_ij| <= N u |K_ij|`` to first order (``u =
eps/2``, little cancellation inside an entry: members' geometric stiffness ``|t|/l`` is
below their elastic ``EA/l0`` wherever the two have opposite signs), hence by Weyl
``|d lambda| <= ||dK_s||_2 <= ||dK_s||_inf <= N u ||K_s||_inf``; the factorisation or
eigensolver adds a backward error of the same order, hence ``2 N u = N eps``. Eigenvalues
within ``rho`` of zero have no sign in double precision (measured on unstressed towers,
whose zero eigenvalues come out within ``1.02 eps ||K_s||_inf``: the bound is ~20x above).

The shifted step (:func:`shifted_step_sparse`): a Cholesky attempt on ``K_s + rho I``; if
it succeeds that is Newton's own step (the shift is below anything the matrix resolves, so
convergence stays quadratic however soft the structure: a fixed shift ``u`` turns it
linear with rate ``u / (lambda + u)`` along modes with ``lambda ~ u``; 22 of the 83
iterations of a 10,000-member spine at ``u = 1e-10``). If it fails the matrix is
indefinite: the smallest shift that makes it positive definite is bracketed to a decade by
a few more attempts (:func:`smallest_definite_shift`), ``lambda_min`` found by
shift-invert Lanczos about that bracket (a Lanczos solve about a fixed shift far from it
needed hundreds of solves near a solution: 17 of 28 s on a 100,000-member tower), and two
steps are offered: the reflection, shift ``2 |lambda_min| + rho`` (the most negative
curvature becomes ``+|lambda_min|``), and the paper's ``u + |lambda_min|`` (Eq. 81) with
``u = rho``, mostly along the negative curvature. Form-finding keeps the one whose line
search ends lower (:mod:`.formfind`): the second alone made steps of ~1/u along a negative
curvature that was local and that the line search then cut to 1e-6 (a 9,000-member
tower: 15 iterations, now 6). A fixed ``u`` (the paper's Eq. 81 on the scaled matrix)
remains as an option.

One rule when a factorisation fails, for both paths and every shift they choose (the
rounding level, the reflection, Eq. 81's ``u + |lambda_min|`` whose computed ``lambda_min``
is only known to rounding): the smallest power of ten above the failed shift that
factors, found two decades at a time and bisected to one decade
(:func:`smallest_definite_shift`, :func:`definite_factor`). It terminates at the Gershgorin
shift ``2 ||K_s||_inf`` (:func:`dominance_shift`): there ``K_s + tau I`` is strictly
diagonally dominant, every row's diagonal exceeding the sum of its off-diagonal magnitudes
by ``||K_s||_inf``, at least a third of the diagonal; elimination keeps that dominance in
every Schur complement, so Cholesky (and the ``L D L^T`` attempt) completes in floating
point. The dense Cholesky needs it: at ``|lambda_min| + rho`` the shifted matrix is singular
to within ``rho``, and on a chain of springs whose stiffnesses span decades (a tridiagonal
``K``) the elimination's rounding exceeds that (7 % of such chains, 43-93 nodes). Only a
matrix with non-finite entries has no such shift: :class:`NoDefiniteShift` says so.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Final, TypeAlias, TypeVar

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import qr
from scipy.sparse.linalg import LinearOperator, SuperLU, eigsh, splu
from threadpoolctl import ThreadpoolController

from tensegrity_core.errors import TensegrityError
from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.rotation import hat
from tensegrity_core.general.stiffness import sym_rotation_hessian

FloatArray = NDArray[np.float64]
T = TypeVar("T")
#: A stiffness matrix: dense array or scipy sparse matrix.
Matrix: TypeAlias = "FloatArray | sp.spmatrix"
_EPS: Final = float(np.finfo(float).eps)


class NoDefiniteShift(TensegrityError, FloatingPointError):
    """No identity shift makes a stiffness matrix positive definite in double precision:
    its entries are not finite (stiffnesses or coordinates beyond double precision)."""


def require_finite(Ks: Matrix) -> None:
    """Raise :class:`NoDefiniteShift` unless every entry of the scaled stiffness is finite."""
    values = Ks.data if sp.issparse(Ks) else np.asarray(Ks)
    if not np.all(np.isfinite(values)):
        raise NoDefiniteShift("the stiffness matrix has non-finite entries: stiffnesses or coordinates beyond "
                              "double precision")


def dominance_shift(Ks: Matrix) -> float:
    """``2 ||K_s||_inf``: the shift that makes ``K_s + tau I`` strictly diagonally dominant,
    so its Cholesky factorisation completes in floating point (module docstring); the
    smallest normal number for a zero matrix."""
    if sp.issparse(Ks):
        row_sum = np.asarray(abs(sp.csr_matrix(Ks)).sum(axis=1)).ravel()
    else:
        row_sum = np.abs(np.asarray(Ks, dtype=float)).sum(axis=1)
    return max(2.0 * float(row_sum.max(initial=0.0)), float(np.finfo(float).tiny))


#: This process's BLAS libraries (found once: inspecting them takes ~20 ms).
_BLAS: ThreadpoolController | None = None


def one_blas_thread() -> AbstractContextManager[object]:
    """A context in which BLAS runs on one thread, for dense algebra of at most a few hundred
    unknowns: a thread more hands over each small factorisation and eigenproblem, and on a
    busy machine its threads wait for cores they spin on (a 40-vertebra C spine, 234 DOF:
    13.4 s of CPU and 61 s of wall time with two BLAS threads under load 12, 1.4 s of CPU
    with one; docs/design/general.md). Process-wide while it lasts, as BLAS's own setting."""
    global _BLAS
    if _BLAS is None:
        _BLAS = ThreadpoolController()
    limit: AbstractContextManager[object] = _BLAS.limit(limits=1, user_api="blas")
    return limit


def claim_blas_memory() -> None:
    """Put BLAS on one thread for good and make it take now the memory it keeps for later
    calls: for a process about to cap its address space (a form-finding worker).

    OpenBLAS (numpy's and scipy's, one library each) keeps work buffers of ``BUFFER_SIZE``
    (32 MiB in their builds) that it maps when a call finds none free, and a forked process
    re-creates the thread pool (thread stacks, a buffer per thread) at its first change of
    thread count (:func:`one_blas_thread`'s). A mapping that fails is retried: without end
    by scipy's 0.3.30 (a worker seen spinning in ``blas_memory_alloc``, OpenBLAS's
    ``driver/others/memory.c``), ten times by numpy's 0.3.31, which then ends the process.
    Under an address-space cap that is a hang or a dead worker, never a ``MemoryError``.
    After this call each library has its pool and a free buffer, and on one thread a call
    takes one buffer and gives it back, so no later call maps another. The products are
    128 x 128: above OpenBLAS's small-matrix kernels (up to 100^3 multiply-adds), which take
    no buffer."""
    global _BLAS
    if _BLAS is None:
        _BLAS = ThreadpoolController()
    _BLAS.limit(limits=1, user_api="blas")
    a = np.eye(128)
    np.matmul(a, a)
    la.blas.dgemm(1.0, a, a)


def as_dense(K: Matrix) -> FloatArray:
    """``K`` as a dense float array."""
    if isinstance(K, np.ndarray):
        return np.asarray(K, dtype=float)
    return np.asarray(K.toarray(), dtype=float)


def jacobi_scaling(K: Matrix) -> FloatArray:
    """``d`` with ``diag(d) K diag(d)`` of unit diagonal (``d_i = |K_ii|^-1/2``; tiny or
    zero diagonals are floored at 1e-12 of the largest, so no entry blows up; all ones for a
    zero matrix)."""
    diag = np.abs(K.diagonal() if sp.issparse(K) else np.diag(np.asarray(K)))
    top = diag.max(initial=0.0)
    if not top > 0:
        return np.ones_like(diag, dtype=float)
    return np.asarray(1.0 / np.sqrt(np.maximum(diag, 1e-12 * top)), dtype=float)


def rounding_level(K: Matrix) -> float:
    """``N eps ||K||_inf`` for a symmetric ``K`` (``N`` the most nonzeros in one row): the
    bound on how far rounding moves its eigenvalues (module docstring)."""
    if sp.issparse(K):
        A = sp.csr_matrix(K)
        row_sum = np.asarray(abs(A).sum(axis=1)).ravel()
        count = np.diff(A.indptr)
    else:
        A_dense: FloatArray = np.asarray(K, dtype=float)
        row_sum = np.abs(A_dense).sum(axis=1)
        count = np.count_nonzero(A_dense, axis=1)
    return float(count.max(initial=1) * _EPS * row_sum.max(initial=0.0))


#: scipy's message for SuperLU's report of a zero pivot; SuperLU's other failures come as
#: RuntimeError too, with its own message (``SUPERLU_MALLOC fails for buf in intCalloc()``).
_SINGULAR: Final = "Factor is exactly singular"


def factor_if_positive_definite(A: sp.spmatrix) -> SuperLU | None:
    """SuperLU ``L D L^T`` factor of the sparse symmetric ``A`` if it is positive definite,
    else ``None`` (see the module docstring). Raises ``MemoryError`` when SuperLU cannot
    allocate (scipy raises some of those as RuntimeError, which must not read as a zero
    pivot: a memory cap would turn into a shift and a wrong verdict)."""
    A = sp.csc_matrix(A)
    try:
        lu = splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options=dict(SymmetricMode=True, Equil=False))
    except RuntimeError as err:
        if str(err) == _SINGULAR:       # an exactly zero pivot: not positive definite
            return None
        if "alloc" in str(err).lower():
            raise MemoryError(f"SuperLU: {err}") from err
        raise
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    d = lu.U.diagonal()
    if not (np.all(d > 0) and np.all(np.isfinite(d))):
        return None
    return lu


def solver(lu: SuperLU, n: int) -> LinearOperator:
    """``x -> A^-1 x`` for the factor ``lu`` of an ``n x n`` matrix, as a LinearOperator."""
    return LinearOperator((n, n), matvec=lambda x: lu.solve(np.asarray(x, dtype=float).ravel()), dtype=float)


@dataclass
class ShiftedStep:
    """A Newton direction from the shifted scaled stiffness (see the module docstring).

    ``dU`` the direction; ``shift`` the identity shift added to the Jacobi-scaled ``K_T``;
    ``min_eigenvalue`` of the scaled ``K_T`` when it was computed (dense path, or an
    indefinite sparse matrix) else ``None``; ``factorizations`` how many were needed;
    ``solve`` applies the same shifted inverse to another right-hand side; ``indefinite``
    whether the scaled ``K_T`` had to be lifted above its rounding level (the step then
    follows negative curvature); ``alternative`` on an indefinite matrix, the step with the
    smallest definite shift ``|lambda_min| + rho`` (Eq. 81 with ``u = rho``: mostly along the
    negative curvature), for the caller to try as well.
    """

    dU: FloatArray
    shift: float
    min_eigenvalue: float | None
    factorizations: int
    solve: Callable[[FloatArray], FloatArray]
    indefinite: bool = False
    alternative: ShiftedStep | None = None


def shifted_step_dense(K: Matrix, P: FloatArray, u: float | None = None) -> ShiftedStep:
    """The paper's procedure with dense algebra: all eigenvalues of the scaled ``K_T`` each
    step, then the shift (``rho`` if positive definite, else as in the module docstring; a
    fixed ``u``: the paper's ``u + max(0, -lambda_min)``), dense Cholesky; a shift whose
    Cholesky fails is raised by the rule of :func:`definite_factor`. Raises
    :class:`NoDefiniteShift` for a matrix with non-finite entries."""
    Kd = as_dense(K)
    d = jacobi_scaling(Kd)
    Ks = d[:, None] * Kd * d[None, :]
    require_finite(Ks)
    lam = float(la.eigvalsh(Ks)[0])
    rho = rounding_level(Ks)
    limit = dominance_shift(Ks)
    eye = np.eye(len(d))

    def attempt(tau: float) -> tuple[FloatArray, bool] | None:
        try:
            factor: tuple[FloatArray, bool] = la.cho_factor(Ks + tau * eye, check_finite=False)
        except la.LinAlgError:
            return None
        return factor

    def step(tau: float, indefinite: bool, alternative: ShiftedStep | None = None) -> ShiftedStep:
        tau, c, tries = definite_factor(attempt, tau, limit)

        def solve(x: FloatArray) -> FloatArray:
            return np.asarray(d * la.cho_solve(c, d * x), dtype=float)

        return ShiftedStep(solve(P), tau, lam, tries, solve, indefinite, alternative)

    if u is not None:
        return step(u + max(0.0, -lam), lam <= 0.0)
    if lam > rho:
        return step(rho, False)
    return step(2.0 * abs(lam) + rho, True, step(abs(lam) + rho, True))


def definite_factor(attempt: Callable[[float], T | None], tau: float, limit: float) -> tuple[float, T, int]:
    """``attempt(tau)`` (a factorisation of the scaled matrix shifted by ``tau``), or when it
    fails the smallest decade above ``tau`` that succeeds, up to the Gershgorin shift
    ``limit`` (:func:`smallest_definite_shift`; module docstring: why it terminates).
    Returns ``(shift, factor, attempts)``."""
    first = attempt(tau)
    if first is not None:
        return tau, first, 1
    shift, factor, tries = smallest_definite_shift(attempt, tau, limit=limit)
    return shift, factor, tries + 1


def shifted_step_sparse(K: Matrix, P: FloatArray, u: float | None = None) -> ShiftedStep:
    """The shifted Newton step on the scaled ``K_T`` with sparse algebra (module docstring).

    ``u`` None: first attempt at the rounding level ``rho``; on an indefinite matrix the
    smallest shift ``tau`` that makes it positive definite is bracketed within a factor 10
    (:func:`smallest_definite_shift`) and the step uses ``2 tau + rho``, which lifts the
    most negative eigenvalue to between ``|lambda_min|`` and ``19 |lambda_min|``. A fixed
    ``u``: the paper's Eq. 81 (first attempt ``u``, then the decade bracket above it, the
    smallest eigenvalue by shift-invert Lanczos, then ``u + |lambda_min|``). Raises
    :class:`NoDefiniteShift` for a matrix with non-finite entries.
    """
    Kc = sp.csr_matrix(K)
    d = jacobi_scaling(Kc)
    D = sp.diags(d)
    Ks = (D @ Kc @ D).tocsc()
    require_finite(Ks)
    n = Ks.shape[0]
    eye = sp.identity(n, format="csc")
    rho = rounding_level(Ks)
    limit = dominance_shift(Ks)

    def attempt(tau: float) -> SuperLU | None:
        return factor_if_positive_definite(Ks + tau * eye)

    first = rho if u is None else u
    tau, lu, tries = definite_factor(attempt, first, limit)
    if tries == 1:
        dU, solve = _scaled_solution(lu, d, P)
        return ShiftedStep(dU, tau, None, 1, solve)
    lam = _nearest_eigenvalue(Ks, tau, lu)
    if u is not None:
        shift = u + max(0.0, -lam)
        better = attempt(shift)
        tries += 1
        if better is not None:
            lu, tau = better, shift
        dU, solve = _scaled_solution(lu, d, P)
        return ShiftedStep(dU, tau, lam, tries, solve, indefinite=True)
    candidates = []
    for shift in (2.0 * abs(lam) + rho, abs(lam) + rho):
        lu_shift = attempt(shift)
        tries += 1
        if lu_shift is None:          # lam's last digits put it just short: the bracket's factor
            shift, lu_shift = tau, lu
        dU, solve = _scaled_solution(lu_shift, d, P)
        candidates.append(ShiftedStep(dU, shift, lam, tries, solve, indefinite=True))
    reflection, along = candidates
    reflection.alternative = along
    return reflection


def _nearest_eigenvalue(Ks: sp.spmatrix, tau: float, lu: SuperLU) -> float:
    """The eigenvalue of ``Ks`` nearest ``-tau`` (its smallest when ``Ks + tau I`` is positive
    definite, factor ``lu``), by shift-invert Lanczos, to 1e-6."""
    n = Ks.shape[0]
    v0 = np.random.default_rng(0).standard_normal(n)
    return float(eigsh(Ks, k=1, sigma=-tau, which="LM", OPinv=solver(lu, n), v0=v0, tol=1e-6,
                       return_eigenvectors=False)[0])


def smallest_definite_shift(attempt: Callable[[float], T | None], failed: float, *,
                            limit: float = 1e16) -> tuple[float, T, int]:
    """The smallest power of ten (to one decade) ``tau > failed`` for which ``attempt(tau)``
    (a factorisation of a matrix shifted by ``tau``) succeeds, with its result and the number
    of attempts: ``1e-8``, then up two decades at a time until one succeeds, then bisection
    of the exponent down to one decade above a failing shift (``failed`` is known to fail).
    The last attempt upwards is ``limit`` itself (a shift known to suffice, e.g.
    :func:`dominance_shift`); raises :class:`NoDefiniteShift` when even that fails."""
    top = float(np.log10(limit))
    lo = float(np.log10(max(failed, 1e-300)))
    hi = min(max(-8.0, np.floor(lo) + 1.0), top)
    if not hi > lo:
        raise NoDefiniteShift(f"no shift up to {limit:.3g} makes the matrix positive definite")
    result, tries = attempt(10.0 ** hi), 1
    while result is None:
        if hi >= top:
            raise NoDefiniteShift(f"no shift up to {limit:.3g} makes the matrix positive definite")
        lo, hi = hi, min(hi + 2.0, top)
        result, tries = attempt(10.0 ** hi), tries + 1
    while hi - lo > 1.0:
        mid = np.ceil(0.5 * (lo + hi)) if hi - lo >= 2.0 else 0.5 * (lo + hi)
        trial, tries = attempt(10.0 ** mid), tries + 1
        if trial is None:
            lo = mid
        else:
            hi, result = mid, trial
    return float(10.0 ** hi), result, tries


def _scaled_solution(lu: SuperLU, d: FloatArray, P: FloatArray) -> tuple[FloatArray, Callable[[FloatArray], FloatArray]]:
    """``K^-1 P`` through the factor ``lu`` of the scaled ``D K D``, and the solve itself."""
    def solve(x: FloatArray) -> FloatArray:
        return np.asarray(d * lu.solve(d * x), dtype=float)

    return solve(P), solve


def rigid_motions(config: Configuration) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Infinitesimal rigid motions of the whole structure in ``U``.

    Returns ``T`` (n_dof, 6): columns are translations x, y, z [per m] and rotations about
    x, y, z through the centroid ``o`` of all nodes, each rotation by the angle ``1 / ell``
    [rad per m] so that it moves the nodes as far as a unit translation does; ``F`` (n_fixed,
    6): the motion each would impose on the fixed coordinates; ``o``; ``ell`` [m], the
    root-mean-square distance of the nodes from ``o`` (1 for a single point). With
    unscaled rotations the columns' sizes differ by ``ell``, and every relative rank test
    on them (supports, rigid modes) would depend on the unit of length: a prism of 1e-15 m
    or of 1e13 m lost its rotations or translations from the excluded modes.
    """
    s = config.structure
    lay = s.layout
    o = config.coords.mean(axis=0)
    arm = config.coords - o
    ell = float(np.sqrt(np.mean(np.sum(arm * arm, axis=1))))
    if not ell > 0.0:
        ell = 1.0
    E = np.eye(3)
    node_motion = np.zeros((s.n_nodes, 3, 6))        # displacement of node i, axis j, motion k
    node_motion[:, :, :3] = E[None]
    node_motion[:, :, 3:] = -hat(arm / ell)             # e_k x d = -hat(d) e_k
    T = np.zeros((lay.n_dof, 6))
    free = lay.free_index >= 0
    T[lay.free_index[free]] = node_motion[free]
    if lay.body_dof.size:
        rows = lay.body_dof[:, None] + np.arange(3)[None, :]
        T[rows.ravel(), :3] = np.tile(E, (len(lay.body_dof), 1))
        T[rows.ravel(), 3:] = (-hat((config.centres - o) / ell)).reshape(-1, 3)
        T[(rows + 3).ravel(), 3:] = np.tile(E / ell, (len(lay.body_dof), 1))
    F = node_motion[lay.fixed_mask]
    return T, F, o, ell


def null_space_of_rows(F: FloatArray) -> FloatArray:
    """Orthonormal basis of ``{v : F v = 0}`` for a tall ``F`` (rows >> columns): from the
    small triangular factor of ``F = Q R`` (``scipy.linalg.null_space`` on ``F`` itself
    computes the full left singular basis, rows x rows: minutes for 10^4 pinned coordinates)."""
    if F.shape[0] > F.shape[1]:
        F = la.qr(F, mode="r")[0][:F.shape[1]]
    return np.asarray(la.null_space(F), dtype=float)


def zero_energy_rigid_modes(config: Configuration) -> FloatArray:
    """Orthonormal basis (n_dof, k) of the rigid-body motions that the supports allow and
    along which the potential is stationary to second order at an equilibrium.

    Translations always qualify (when allowed); rotations qualify unless dead loads or
    weights make the potential change to second order along them (load stiffness), in
    which case they are part of the stability question and are kept.
    """
    s = config.structure
    T, F, o, ell = rigid_motions(config)
    N = null_space_of_rows(F) if F.shape[0] else np.eye(6)
    if N.shape[1] == 0:
        return np.zeros((T.shape[0], 0))
    f = s.external_forces
    lay = s.layout
    HL = np.zeros((6, 6))
    HL[3:, 3:] = sym_rotation_hessian(-f, config.coords - o).sum(axis=0)
    w = lay.body_masses[:, None] * s.gravity[None, :]
    if w.size:
        HL[3:, 3:] += sym_rotation_hessian(-w, config.centres - o).sum(axis=0)
    HL[3:, 3:] /= ell * ell          # per (rotation ell) squared, as T's rotation columns
    scale = float(np.sum(np.linalg.norm(f, axis=1) * np.linalg.norm(config.coords - o, axis=1)))
    if w.size:
        scale += float(np.sum(np.linalg.norm(w, axis=1) * np.linalg.norm(config.centres - o, axis=1)))
    scale /= ell * ell
    Hn = N.T @ HL @ N
    mu, Y = np.linalg.eigh(0.5 * (Hn + Hn.T))
    keep = np.abs(mu) <= 1e-10 * scale if scale > 0 else np.ones(len(mu), dtype=bool)
    if not keep.any():
        return np.zeros((T.shape[0], 0))
    Z = T @ (N @ Y[:, keep])
    q, r = np.linalg.qr(Z)
    rank = int(np.sum(np.abs(np.diag(r)) > 1e-12 * max(np.abs(r).max(), 1e-300)))
    return np.asarray(q[:, :rank], dtype=float)


def moving_coordinates(config: Configuration) -> NDArray[np.int64]:
    """Indices of ``U`` that Newton moves: all but one coordinate per zero-energy rigid-body
    motion of an unsupported structure (chosen by pivoted QR, so the rest is transversal to
    those motions). Off equilibrium ``K_T`` is not singular along rigid motions, only nearly
    so and possibly negative; left in, they swamp the shifted Newton step."""
    n = config.structure.layout.n_dof
    Z = zero_energy_rigid_modes(config)
    if Z.shape[1] == 0:
        return np.arange(n)
    _, _, piv = qr(Z.T, pivoting=True, mode="economic")
    return np.setdiff1d(np.arange(n), piv[:Z.shape[1]])
