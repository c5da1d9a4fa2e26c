"""The stability verdict: the smallest eigenvalue of ``K_T`` on the free space, and its sign.

The stability eigenvalue is the smallest eigenvalue of ``K_T`` on the complement of the
zero-energy rigid-body motions ``Z`` (:func:`~.linalg.zero_energy_rigid_modes`): physical
(``value``, units of ``U``) and of the Jacobi-scaled ``K_s = D K_T D`` (``scaled``,
dimensionless). Its sign decides, against the rounding level ``rho`` of ``K_s``
(:func:`~.linalg.rounding_level`, the bound on what rounding does to its eigenvalues):
stable above ``rho``, unstable below ``-rho``, neutral (no sign in double precision: an
unstiffened mechanism, or stiffness too small to resolve) in between; ``margin = scaled /
rho``. Scaling changes the eigenvalues but not their signs (Sylvester: ``K_s`` is congruent
to ``K_T``), and it makes the rounding bound tight: each member's terms are measured
against the stiffness of the coordinates it joins.

Sparse: shift-invert Lanczos (``eigsh``) about ``-beta`` on the pencil of
:class:`_ComplementPencil` (``K`` on the complement of ``Z``, exactly, with one coordinate
per rigid mode held so that the sparse factor has no rigid-body null space). ``beta`` is
the rounding level when ``K + beta`` is positive definite there (the shift then sits at zero
for anything the matrix resolves, so Lanczos finds the smallest eigenvalue in a few dozen
steps however small it is), else the smallest decade that makes it so
(:func:`~.linalg.smallest_definite_shift`): every eigenvalue lies above ``-beta``, the one
nearest it is the smallest. When the scaled pencil is positive definite at zero shift (a
stable structure) one factor serves both the scaled and the physical eigenvalue (``K =
D^-1 K_s D^-1``), each found by Lanczos about zero. A shift far above the smallest eigenvalue
(the earlier ``beta = 1e-9 max |K_ii|``) leaves Lanczos to separate eigenvalues whose
distances are tiny next to it: 128 s instead of 0.4 s on a 100,000-member tower.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import qr
from scipy.sparse.linalg import LinearOperator, eigsh

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.linalg import (
    Matrix,
    as_dense,
    factor_if_positive_definite,
    jacobi_scaling,
    rounding_level,
    smallest_definite_shift,
    zero_energy_rigid_modes,
)

FloatArray = NDArray[np.float64]


@dataclass
class LowestMode:
    """Smallest eigenvalue of ``K_T`` on the complement of the excluded rigid-body modes,
    physical (``value``, mixed units of ``U``) and of the Jacobi-scaled matrix (``scaled``,
    dimensionless), the scaled mode mapped back to ``U`` (``vector``), the number of
    excluded rigid-body modes and the rounding level ``rounding`` of the scaled matrix."""

    value: float
    scaled: float
    vector: FloatArray
    rigid_body_modes: int
    rounding: float

    @property
    def margin(self) -> float:
        """``scaled / rounding``: above 1 stable, below -1 unstable, else neutral. A matrix of
        zeros (every member slack or unstressed and unstiffened) has rounding level 0: its
        zero eigenvalue has margin 0 (neutral), any other eigenvalue +-inf."""
        if self.rounding > 0:
            return self.scaled / self.rounding
        return float(np.sign(self.scaled)) * np.inf if self.scaled != 0 else 0.0

    @property
    def verdict(self) -> str:
        """``"stable"``, ``"unstable"`` or ``"neutral"`` (see :attr:`margin`)."""
        return "stable" if self.margin > 1.0 else "unstable" if self.margin < -1.0 else "neutral"


def lowest_mode(K: Matrix, config: Configuration, *, dense: bool) -> LowestMode:
    """The stability eigenvalue of ``K_T`` at an equilibrium ``config`` (see :class:`LowestMode`)."""
    Z = zero_energy_rigid_modes(config)
    d = jacobi_scaling(K)
    Zs = _orthonormal(Z / d[:, None])
    if dense:
        Kd = as_dense(K)
        Ks = d[:, None] * Kd * d[None, :]
        value, _ = _complement_lowest_dense(Kd, Z)
        scaled, vs = _complement_lowest_dense(Ks, Zs)
        return LowestMode(value, scaled, d * vs, Z.shape[1], rounding_level(Ks))
    Kc = sp.csr_matrix(K)
    D = sp.diags(d)
    Ks_sparse = sp.csr_matrix(D @ Kc @ D)
    rho = rounding_level(Ks_sparse)
    if Kc.shape[0] == Z.shape[1]:
        return LowestMode(float("inf"), float("inf"), np.zeros(Kc.shape[0]), Z.shape[1], rho)
    kept = _kept_coordinates(Zs)
    scaled_pencil, pencil = _ComplementPencil(Ks_sparse, Zs, kept), _ComplementPencil(Kc, Z, kept)
    inverse_scaled = inverse_physical = None
    lu = factor_if_positive_definite(scaled_pencil.A)       # one factor at zero shift serves both
    if lu is not None:
        dk = d[kept]

        def scaled_solve(x: FloatArray) -> FloatArray:
            return np.asarray(lu.solve(x), dtype=float)

        def physical_solve(x: FloatArray) -> FloatArray:       # K[kept, kept] = D^-1 Ks[kept, kept] D^-1
            scale = dk if x.ndim == 1 else dk[:, None]
            return np.asarray(scale * lu.solve(scale * x), dtype=float)

        inverse_scaled = scaled_pencil.inverse(0.0, scaled_solve)
        inverse_physical = pencil.inverse(0.0, physical_solve)
    scaled, vs = _lanczos(scaled_pencil, inverse_scaled, rho)
    # the scaled mode, mapped to U, starts the physical solve (a cluster of nearly equal
    # eigenvalues, repeated units, took 151 solves from a random start, 61 from it)
    value, _ = _lanczos(pencil, inverse_physical, rounding_level(Kc), start=(d * vs)[kept])
    return LowestMode(value, scaled, d * vs, Z.shape[1], rho)


def _complement_lowest_dense(K: FloatArray, Z: FloatArray) -> tuple[float, FloatArray]:
    n = K.shape[0]
    if Z.shape[1] == 0:
        w, V = la.eigh(K, subset_by_index=[0, 0])
        return float(w[0]), np.asarray(V[:, 0], dtype=float)
    C = la.null_space(Z.T)
    if C.shape[1] == 0:
        return float("inf"), np.zeros(n)
    w, V = la.eigh(C.T @ K @ C, subset_by_index=[0, 0])
    return float(w[0]), np.asarray(C @ V[:, 0], dtype=float)


def _kept_coordinates(Z: FloatArray) -> NDArray[np.int64]:
    """All coordinates but one per column of ``Z``, chosen by pivoted QR of ``Z^T`` (so the
    rows of ``Z`` left out are well conditioned)."""
    n, k = Z.shape
    if k == 0:
        return np.arange(n)
    _, _, piv = qr(Z.T, pivoting=True, mode="economic")
    return np.setdiff1d(np.arange(n), piv[:k])


def _lanczos(pencil: _ComplementPencil, inverse: Callable[[FloatArray], FloatArray] | None,
             rho: float, start: FloatArray | None = None) -> tuple[float, FloatArray]:
    """Smallest eigenvalue of the pencil and its unit eigenvector (in the full space), by
    shift-invert Lanczos about zero with ``inverse`` (``(A')^-1``), or when that is None
    about ``-beta``, the rounding level or the smallest decade that makes ``A' + beta M``
    positive definite (module docstring); from ``start`` (kept coordinates) if given, to a
    relative accuracy of 1e-8."""
    beta = 0.0
    if inverse is None:
        beta = max(rho, float(np.finfo(float).tiny))
        inverse = pencil.inverse(beta)
    if inverse is None:
        beta, solve, _ = smallest_definite_shift(pencil.inverse, beta)
    else:
        solve = inverse
    m = len(pencil.kept)

    def op(f: Callable[[FloatArray], FloatArray]) -> LinearOperator:
        return LinearOperator((m, m), matvec=f, dtype=float)

    v0 = np.random.default_rng(0).standard_normal(m) if start is None else start
    metric = op(pencil.metric) if pencil.k else None          # M = I without rigid modes
    w, V = eigsh(op(pencil.matvec), k=1, M=metric, sigma=-beta, which="LM", OPinv=op(solve), v0=v0, tol=1e-8)
    vector = pencil.lift(V[:, 0])
    return float(w[0]), vector / np.linalg.norm(vector)


class _ComplementPencil:
    """``K`` on the complement of the orthonormal rigid modes ``Z`` as a sparse pencil.

    Holding one coordinate per mode (pivoted QR of ``Z^T``: the held rows of ``Z`` are well
    conditioned), the rest ``w`` (indices ``kept``) maps one to one onto the complement by
    ``p = P E w``, ``P = I - Z Z^T``. There ``p^T K p = w^T A' w`` and ``p^T p = w^T M w`` with
    ``A' = A - G Y^T - Y G^T + Y S Y^T`` (``A = K[kept, kept]`` sparse, ``Y = Z[kept]``, ``G =
    (K Z)[kept]``, ``S = Z^T K Z``) and ``M = I - Y Y^T``: the eigenvalues of ``K`` on the
    complement are exactly those of the pencil ``(A', M)``. ``A`` has no rigid-body null
    space, so its factor is as well conditioned as the structure, and ``A' + beta M`` is
    ``A + beta I`` plus the rank-``2k`` term ``U C U^T`` (``U = [Y, G]``, ``C = [[S - beta I,
    -I], [-I, 0]]``), inverted by Woodbury. No rigid modes (``k = 0``): ``A' = K``, ``M = I``.
    """

    def __init__(self, K: sp.csr_matrix, Z: FloatArray, kept: NDArray[np.int64]) -> None:
        n, k = K.shape[0], Z.shape[1]
        self.n, self.k, self.Z, self.kept = n, k, Z, kept
        if k:
            KZ = np.asarray(K @ Z, dtype=float)
            self.A = sp.csc_matrix(K[kept][:, kept])
            self.Y, self.G, self.S = Z[kept], KZ[kept], Z.T @ KZ
        else:
            self.A = sp.csc_matrix(K)

    def matvec(self, w: FloatArray) -> FloatArray:
        """``A' w``."""
        w = np.asarray(w, dtype=float).ravel()
        out = np.asarray(self.A @ w, dtype=float)
        if self.k:
            yw, gw = self.Y.T @ w, self.G.T @ w
            out += -self.G @ yw - self.Y @ gw + self.Y @ (self.S @ yw)
        return out

    def metric(self, w: FloatArray) -> FloatArray:
        """``M w``."""
        w = np.asarray(w, dtype=float).ravel()
        return w - self.Y @ (self.Y.T @ w) if self.k else w

    def lift(self, w: FloatArray) -> FloatArray:
        """``p = P E w`` in the full space."""
        p = np.zeros(self.n)
        p[self.kept] = w
        return p - self.Z @ (self.Y.T @ w) if self.k else p

    def inverse(self, beta: float, factor: Callable[[FloatArray], FloatArray] | None = None
                ) -> Callable[[FloatArray], FloatArray] | None:
        """``x -> (A' + beta M)^-1 x`` if ``A' + beta M`` is positive definite, else None.
        ``factor`` solves with ``A + beta I`` (known positive definite) when already factored.

        With ``F = (A + beta I)^-1`` positive definite, ``A' + beta M = F^-1 + U C U^T`` is
        congruent to ``I + F^1/2 U C U^T F^1/2``, whose eigenvalues other than 1 are those of
        ``I + R^1/2 C R^1/2`` (``R = U^T F U``, 2k x 2k): it is positive definite iff that small
        matrix is. Its inverse is ``F - F U C (I + R C)^-1 U^T F`` (Woodbury in the form without
        ``C^-1``, whose entries span ``beta`` to ``1/beta``)."""
        if factor is None:
            lu = factor_if_positive_definite(self.A + beta * sp.identity(self.A.shape[0], format="csc"))
            if lu is None:
                return None
            factor = lu.solve
        solve_A = factor
        if not self.k:
            return lambda x: np.asarray(solve_A(np.asarray(x, dtype=float).ravel()), dtype=float)
        k = self.k
        U = np.hstack([self.Y, self.G])
        FU = solve_A(U)
        C = np.block([[self.S - beta * np.eye(k), -np.eye(k)], [-np.eye(k), np.zeros((k, k))]])
        R = U.T @ FU
        r, V = np.linalg.eigh(0.5 * (R + R.T))
        root = (V * np.sqrt(np.maximum(r, 0.0))) @ V.T
        small = np.eye(2 * k) + root @ C @ root
        if np.linalg.eigvalsh(0.5 * (small + small.T)).min() <= 1e-12:
            return None
        correction = C @ np.linalg.inv(np.eye(2 * k) + R @ C)

        def solve(x: FloatArray) -> FloatArray:
            y = solve_A(np.asarray(x, dtype=float).ravel())
            return np.asarray(y - FU @ (correction @ (U.T @ y)), dtype=float)

        return solve


def _orthonormal(Z: FloatArray) -> FloatArray:
    if Z.shape[1] == 0:
        return Z
    q, _ = np.linalg.qr(Z)
    return np.asarray(q, dtype=float)
