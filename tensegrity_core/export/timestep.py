"""The time step of an exported model, from the fastest rate of its linearised dynamics.

A fixed-step integrator (MuJoCo's RK4, semi-implicit Euler) is stable and accurate only
while ``|lambda| dt`` stays small for every eigenvalue ``lambda`` of the linearised motion
``M x'' + D x' + K x = 0``. For an eigenpair ``(lambda, x)`` with ``x^H M x = 1``,
``lambda^2 + d lambda + k = 0`` with ``d = x^H D x`` in ``[0, delta]`` (``delta`` the largest
eigenvalue of ``(D, M)``: the dampers are passive) and ``|k| <= kappa`` (the largest
``|eigenvalue|`` of ``(K, M)``), hence::

    |lambda| <= d/2 + sqrt(d^2/4 + |k|) <= delta + sqrt(kappa)  =: rate  [1/s]

The default step is the largest number of seconds of the form 1, 2 or 5 times a power of
ten that is at most :data:`STEP_RATE_PRODUCT` ``/ rate``: ``|lambda| dt <= 0.2``. That is
far inside RK4's stability region (which reaches 2.8 on both axes), leaving room for strings
that stiffen under larger tensions than at the start, and accurate on the fastest mode: per
period of an undamped mode of frequency ``omega`` (``2 pi / (omega dt)`` steps) RK4 loses
``2 pi (omega dt)^5 / 144`` of its amplitude and ``2 pi (omega dt)^4 / 120`` rad of its
phase, 1.4e-5 and 8.4e-5 at ``omega dt = 0.2``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg

#: ``|lambda| dt`` of the default step on the bound of the fastest rate.
STEP_RATE_PRODUCT = 0.2
#: Up to this many degrees of freedom the eigenvalues are found densely.
DENSE_DOF = 600


def largest_eigenvalue_magnitude(A: Any, M: Any) -> float:
    """The largest ``|eigenvalue|`` of the symmetric pencil ``(A, M)``, ``M`` positive definite
    (scipy.sparse or dense matrices; untyped: Any)."""
    n = A.shape[0]
    if n == 0:
        return 0.0
    if n <= DENSE_DOF:
        Ad = A.toarray() if sp.issparse(A) else np.asarray(A)
        Md = M.toarray() if sp.issparse(M) else np.asarray(M)
        w = scipy.linalg.eigh(0.5 * (Ad + Ad.T), Md, eigvals_only=True)
        return float(np.max(np.abs(w)))
    w = scipy.sparse.linalg.eigsh(sp.csc_matrix(0.5 * (A + A.T)), k=1, M=sp.csc_matrix(M), which="LM",
                                  return_eigenvectors=False, tol=1e-3)
    return float(abs(w[0])) * (1 + 1e-3)


def fastest_rate(M: Any, K: Any, D: Any | None) -> float:
    """``delta + sqrt(kappa)`` [1/s] (see the module docstring): a bound on ``|lambda|`` of the
    linearised dynamics with mass ``M``, stiffness ``K`` and damping ``D`` (or None)."""
    rate = math.sqrt(largest_eigenvalue_magnitude(K, M))
    if D is not None:
        rate += largest_eigenvalue_magnitude(D, M)
    return rate


def default_timestep(rate: float) -> float:
    """The default step [s] for the bound ``rate`` [1/s] on the fastest rate (module docstring)."""
    return round_down_125(STEP_RATE_PRODUCT / rate)


def round_down_125(x: float) -> float:
    """The largest ``{1, 2, 5} x 10^k`` that is at most ``x > 0`` (``0.0037 -> 0.002``)."""
    exponent = math.floor(math.log10(x))
    for mantissa in (5.0, 2.0, 1.0):
        value = float(f"{mantissa:g}e{exponent}")
        if value <= x * (1 + 1e-12):
            return value
    return float(f"5e{exponent - 1}")
