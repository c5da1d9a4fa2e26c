"""Inverse kinematics of the class-2 mechanism over arrays of targets, without a Python loop.

The vectorised counterpart of :func:`~tensegrity_core.class2.inverse_kinematics.inverse_kinematics`:
the same route (the paper's Eq. 13, then the factored roots of the quadratic), the same
snapping of limits (:data:`~tensegrity_core.class2.inverse_kinematics.DOMAIN_TOL`,
:func:`~tensegrity_core.class2.inverse_kinematics.rho1_snap_bound`,
:func:`~tensegrity_core.class2.inverse_kinematics.snap_tolerance`), the same merging of
coincident roots (:func:`~tensegrity_core.class2.inverse_kinematics.merge_radius`) and the same verdicts,
as codes (:data:`IK_CODES`). The derivation is in that module's docstring and
docs/class2.md.

- :func:`ik_array`: the paper-range branch (``delta1 = -1, delta2 = +1``) only, fast;
- :func:`ik_array_all`: all four branches (:data:`IK_BRANCHES`), classified.

Lengths in metres, angles in radians from +X, counter-clockwise.
"""

from __future__ import annotations

from typing import Final, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.inverse_kinematics import (
    DOMAIN_TOL,
    EPS,
    REASON_DUPLICATE,
    REASON_MAXIMUM,
    REASON_NOT_STATIONARY,
    REASON_RANGE,
    REASON_RHO1,
    REASON_RHO2,
    REASON_SUM,
    merge_radius,
    rho1_snap_bound,
)
from tensegrity_core.class2.kinematics import BETA_RANGE_TOL
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params


def _snap_tolerance_array(c: NDArray[np.float64], L: float) -> NDArray[np.float64]:
    """Vectorised :func:`~tensegrity_core.class2.inverse_kinematics.snap_tolerance` (``c >= 0``)."""
    with np.errstate(divide="ignore"):
        return DOMAIN_TOL * L + np.where(c > 0.0, 8.0 * EPS * L * L / c, 0.0)


def _rho1_snap_bound_array(w: NDArray[np.float64], L: float) -> NDArray[np.float64]:
    """Vectorised :func:`~tensegrity_core.class2.inverse_kinematics.rho1_snap_bound`."""
    t = DOMAIN_TOL * L
    return 2.0 * L * t / (np.sqrt(w * w + 2.0 * L * t) + w)


def _on_sum_limit_array(rho1: NDArray[np.float64], rho2: NDArray[np.float64], L: float) -> NDArray[np.float64]:
    """Vectorised :func:`~tensegrity_core.class2.inverse_kinematics.on_sum_limit` for the
    entries put on ``rho1 + rho2 = 2L`` (a sum up to two ulps above 2L moves down)."""
    for _ in range(2):
        rho2 = np.where((rho1 + rho2 > 2.0 * L) & (rho1 + rho2 <= 2.0 * L * (1.0 + 4.0 * EPS)),
                        np.nextafter(rho2, -np.inf), rho2)
    return rho2


def _snap_rho2_array(rho1: NDArray[np.float64], rho2: NDArray[np.float64], c: NDArray[np.float64],
                     y: NDArray[np.float64], tol: NDArray[np.float64], params: Class2Params) -> NDArray[np.float64]:
    """rho2 put on 0 within ``tol`` where FK then reproduces the branch's target
    ``(rho1 + c, y)`` to within ``tol``, and on ``rho1 + rho2 = 2L`` within ``tol`` (as the
    scalar IK's ``_candidate``)."""
    L, k2 = params.L, params.k2
    snapped = np.where((rho2 < 0.0) & (rho2 >= -tol), 0.0, rho2)
    s = rho1 + snapped
    d = (2.0 * params.k3 + k2) * snapped - k2 * rho1
    e = k2 * np.sqrt(np.maximum(0.0, (2.0 * L - s) * (2.0 * L + s)))
    R = np.hypot(d, e)
    residual = np.hypot(rho1 + L * d / R - (rho1 + c), L * e / R - y)   # as the scalar fk_residual
    rho2 = np.where((snapped == rho2) | (residual <= tol), snapped, rho2)
    over = rho1 + rho2 - 2.0 * L
    return _on_sum_limit_array(rho1, np.where((over > 0.0) & (over <= tol), 2.0 * L - rho1, rho2), L)


#: ``(delta1, delta2)`` of the columns of :func:`ik_array_all`.
IK_BRANCHES: Final = ((-1, 1), (-1, -1), (1, -1), (1, 1))
#: Meaning of the codes of :func:`ik_array_all` (index = code); the first failed test wins.
IK_CODES: Final = (
    "",                                  # 0 valid, in the paper's range
    "valid, " + REASON_RANGE,            # 1 genuine equilibrium with beta > pi/2 (or y < 0)
    "no real root",                      # 2
    REASON_RHO1,                         # 3
    REASON_RHO2,                         # 4
    REASON_SUM,                          # 5
    REASON_NOT_STATIONARY,               # 6
    REASON_MAXIMUM,                      # 7
    REASON_DUPLICATE,                    # 8
)


class IKArrays(NamedTuple):
    """Vectorised IK of the paper-range branch; NaN exactly where ``valid`` is False."""

    rho1: NDArray[np.float64]
    rho2: NDArray[np.float64]
    beta: NDArray[np.float64]
    valid: NDArray[np.bool_]


class IKAllArrays(NamedTuple):
    """All four branches: arrays of shape ``target_shape + (4,)``, columns :data:`IK_BRANCHES`.

    ``code`` indexes :data:`IK_CODES`; 0 and 1 are genuine stable equilibria in the
    configuration domain (1: outside the paper's angle range).
    """

    rho1: NDArray[np.float64]
    rho2: NDArray[np.float64]
    beta: NDArray[np.float64]
    code: NDArray[np.int8]


def _snap_array(v: NDArray[np.float64], lo: float, hi: float, tol: float | NDArray[np.float64]) -> NDArray[np.float64]:
    v = np.where((v < lo) & (v >= lo - tol), lo, v)
    return np.where((v > hi) & (v <= hi + tol), hi, v)


def _branch_array(
    x: NDArray[np.float64], y: NDArray[np.float64], w: NDArray[np.float64], d1: float | NDArray[np.float64], L: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Vectorised ``_branch`` of :mod:`~tensegrity_core.class2.inverse_kinematics`."""
    raw = x + d1 * w
    rho1 = _snap_array(raw, 0.0, L, _rho1_snap_bound_array(w, L))
    moved = rho1 != raw
    r = np.hypot(x - rho1, y)
    c = np.where(moved, L * (x - rho1) / r, -d1 * w)
    y = np.where(moved, L * y / r, y)
    return rho1, c, y


def _paper_branch(
    x: NDArray[np.float64], y: NDArray[np.float64], params: Class2Params
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(rho1, rho2, c)`` of the paper branch without any snapping (the fast path).

    Written with in-place operations on three scratch arrays: at a million targets the
    cost of the formulas is dominated by allocating and touching fresh arrays.
    """
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    yy = np.multiply(y, y)
    cc = np.subtract(L, y)
    t = np.add(L, y)
    cc *= t                                   # c^2 = (L - y)(L + y)
    c = np.sqrt(cc)
    rho1 = np.subtract(x, c)
    xi2 = np.multiply(yy, K * K)
    np.multiply(cc, k2 * k2, out=t)
    xi2 += t                                  # xi2 = K^2 y^2 + k2^2 c^2
    q = np.multiply(rho1, K + k2)
    q *= q
    q *= yy
    np.multiply(xi2, 4.0 * L * L, out=t)
    np.subtract(t, q, out=q)
    np.sqrt(q, out=q)                         # Q
    q *= c
    np.multiply(cc, k2, out=t)
    np.multiply(yy, K, out=cc)
    t -= cc
    t *= rho1                                 # rho1 (k2 c^2 - K y^2)
    q -= t
    q *= k2
    q /= xi2                                  # rho2 = k2 (c Q - rho1 (k2 c^2 - K y^2)) / xi2
    return rho1, q, c


def _paper_branch_snapped(
    x: NDArray[np.float64], y: NDArray[np.float64], params: Class2Params
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`_paper_branch` with the snapping of the scalar IK."""
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    y = np.where((y >= L - DOMAIN_TOL * L) & (y <= L + DOMAIN_TOL * L), L, y)   # as the scalar IK
    y = np.where((y >= -DOMAIN_TOL * L) & (y < 0.0), 0.0, y)
    w = np.sqrt((L - y) * (L + y))
    rho1, c, y = _branch_array(x, y, w, -1.0, L)
    tol = _snap_tolerance_array(np.abs(c), L)
    cc, yy = c * c, y * y
    xi2 = K * K * yy + k2 * k2 * cc
    q = np.sqrt(4.0 * L * L * xi2 - ((K + k2) * rho1) ** 2 * yy)
    rho2 = k2 * (c * q - rho1 * (k2 * cc - K * yy)) / xi2
    return rho1, _snap_rho2_array(rho1, rho2, c, y, tol, params), c, y


def ik_array(x: ArrayLike, y: ArrayLike, params: Class2Params = PAPER_PARAMS) -> IKArrays:
    """IK of the paper-range branch (``delta1 = -1, delta2 = +1``) over arrays, no Python loop.

    For ``0 <= y <= L`` and ``0 <= rho1 <= L`` this root is the unique equilibrium with
    ``0 <= beta <= pi/2`` (module docstring); ``valid`` adds the configuration domain.
    Same snapping of limits as
    :func:`~tensegrity_core.class2.inverse_kinematics.inverse_kinematics`: the formulas run unsnapped on
    every target, then the few targets within snapping distance of a limit (at most
    ``sqrt(2 DOMAIN_TOL) L = 1.4e-6 L`` for lengths, :func:`rho1_snap_bound` on the fold) are
    recomputed with snapping.
    """
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    shape = x.shape
    x, y = x.reshape(-1), y.reshape(-1)
    L = params.L
    band = rho1_snap_bound(0.0, L)   # >= every snap bound: of rho1, and of rho2 for c >= sqrt(2 DOMAIN_TOL) L
    fold = DOMAIN_TOL * L
    with np.errstate(invalid="ignore", divide="ignore"):
        rho1, rho2, c = _paper_branch(x, y, params)
        s = rho1 + rho2
        valid = (y >= 0.0) & (rho1 >= 0.0) & (rho1 <= L) & (rho2 >= 0.0) & (s <= 2.0 * L)
        edge = ((y >= L - fold) & (y <= L + fold)) | ((y >= -fold) & (y < 0.0)) | (
            ~valid & (y >= 0.0) & (rho1 >= -band) & (rho1 <= L + band) & (rho2 >= -band)
            & (s <= 2.0 * L + band))
        yb = y
        if edge.any():
            idx = np.nonzero(edge)
            yb = np.array(y, copy=True)
            rho1[idx], rho2[idx], c[idx], yb[idx] = _paper_branch_snapped(x[idx], y[idx], params)
            valid = (yb >= 0.0) & (yb <= L) & (rho1 >= 0.0) & (rho1 <= L) & (rho2 >= 0.0) & (
                rho1 + rho2 <= 2.0 * L)
        beta = np.arctan2(yb, c)
        valid &= beta <= 0.5 * np.pi + BETA_RANGE_TOL   # a rho1 snapped onto 0 can leave c < 0
    invalid = ~valid
    for a in (rho1, rho2, beta):
        np.copyto(a, np.nan, where=invalid)
    return IKArrays(rho1.reshape(shape), rho2.reshape(shape), beta.reshape(shape), valid.reshape(shape))


def ik_array_all(x: ArrayLike, y: ArrayLike, params: Class2Params = PAPER_PARAMS) -> IKAllArrays:
    """Every candidate of the paper's route over arrays of targets, classified, no Python loop.

    The vectorised counterpart of
    :func:`~tensegrity_core.class2.inverse_kinematics.inverse_kinematics` (same formulas and tests).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    x, y = np.broadcast_arrays(x, y)
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    fold = DOMAIN_TOL * L
    d1 = np.array([b[0] for b in IK_BRANCHES], dtype=float)
    d2 = np.array([b[1] for b in IK_BRANCHES], dtype=float)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        y = np.where((np.abs(y) >= L - fold) & (np.abs(y) <= L + fold), np.copysign(L, y), y)
        y = np.where((y >= -fold) & (y < 0.0), 0.0, y)[..., None]
        w = np.sqrt((L - y) * (L + y))
        rho1, c, y = _branch_array(x[..., None], y, w, d1, L)
        tol = _snap_tolerance_array(np.abs(c), L)
        xi2 = K * K * y * y + k2 * k2 * c * c
        q = np.sqrt(4.0 * L * L * xi2 - ((K + k2) * rho1 * y) ** 2)
        rho2 = k2 * (-rho1 * (k2 * c * c - K * y * y) + d2 * np.abs(c) * q) / xi2
        rho2 = _snap_rho2_array(rho1, rho2, c, y, tol, params)
        s = rho1 + rho2
        lam1 = np.sqrt(np.maximum((2.0 * L - s) * (2.0 * L + s), 0.0))
        d = K * rho2 - k2 * rho1
        beta = np.arctan2(y, c)
        code = np.where(beta > 0.5 * np.pi + BETA_RANGE_TOL, 1, 0)
        code = np.where(beta < -BETA_RANGE_TOL, 1, code)
        # root verdicts as the scalar IK's _spurious_reason: by branch inside the ellipse range, else numeric
        sign_c = np.where(c == 0.0, -d1, np.sign(c))   # = -delta1 unless rho1 was snapped
        genuine_branch = (d2 == sign_c) | ((c == 0.0) & (y > 0.0))
        by_branch = np.where(genuine_branch, np.where(y >= 0.0, 0, 6), np.where(y > 0.0, 6, 7))
        grad2 = y * d - c * k2 * lam1
        numeric = np.where(
            np.abs(grad2) > 0.5 * (np.abs(y * d) + np.abs(c * k2 * lam1)), 6,
            np.where(c * d + k2 * lam1 * y < 0.0, 7, 0))
        verdict = np.where(np.abs(rho1) * (K + k2) < 2.0 * K * L, by_branch, numeric)
        code = np.where(verdict != 0, verdict, code)
        code = np.where(s > 2.0 * L, 5, code)
        code = np.where(rho2 < 0.0, 4, code)
        code = np.where((rho1 < 0.0) | (rho1 > L), 3, code)
        code = np.where(~(np.isfinite(rho2) & np.isfinite(x[..., None])), 2, code)
        merge = merge_radius(L)
        for j in range(1, 4):   # a valid root within merge_radius of an earlier valid one: a duplicate
            near = np.hypot(rho1[..., :j] - rho1[..., j:j + 1], rho2[..., :j] - rho2[..., j:j + 1]) <= merge
            dup = (near & (code[..., :j] <= 1)).any(axis=-1) & (code[..., j] <= 1)
            code[..., j] = np.where(dup, 8, code[..., j])
    return IKAllArrays(rho1, rho2, beta, code.astype(np.int8))
