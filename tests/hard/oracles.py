"""Independent high-precision oracles for the hard-case catalogue (mpmath, 50 digits).

Every float input is converted exactly (``mpf(x)`` keeps all 53 bits), so the difference
between a double-precision result and these values is the error of the double-precision
computation alone, not of the input rounding.
"""

from __future__ import annotations

import mpmath as mp

from tensegrity_core.class2 import PAPER_PARAMS

mp.mp.dps = 50


def fk_exact(rho1: float, rho2: float, params=PAPER_PARAMS):
    """(beta, x, y) of the energy minimum (Eq. 10, root choice of docs/class2.md), 50 digits."""
    L, k2, k3 = (mp.mpf(params.L), mp.mpf(params.k2), mp.mpf(params.k3))
    r1, r2 = mp.mpf(rho1), mp.mpf(rho2)
    s = r1 + r2
    lam1 = mp.sqrt((2 * L - s) * (2 * L + s))
    beta = mp.atan2(k2 * lam1, (2 * k3 + k2) * r2 - k2 * r1)
    return beta, r1 + L * mp.cos(beta), L * mp.sin(beta)


def fk_residual(rho1: float, rho2: float, x: float, y: float, params=PAPER_PARAMS) -> float:
    """|FK(rho1, rho2) - (x, y)| [m] evaluated in 50 digits (backward error of an IK answer)."""
    _, X, Y = fk_exact(rho1, rho2, params)
    return float(mp.hypot(X - mp.mpf(x), Y - mp.mpf(y)))


def ik_exact(x: float, y: float, delta1: int, params=PAPER_PARAMS):
    """(rho1, rho2) of the genuine root of branch ``delta1`` (docs/class2.md: rho1 from
    Eq. 13, then rho2 solving tan(beta) = e/d for the target angle), by bisection in 50 digits."""
    L, k2, k3 = (mp.mpf(params.L), mp.mpf(params.k2), mp.mpf(params.k3))
    X, Y = mp.mpf(x), mp.mpf(y)
    c = -delta1 * mp.sqrt(L**2 - Y**2)          # x - rho1
    r1 = X - c
    beta_t = mp.atan2(Y, c)

    def g(r2):                                   # beta(rho1, r2) - target: decreasing in r2
        s = r1 + r2
        lam1 = mp.sqrt(max(mp.mpf(0), (2 * L - s) * (2 * L + s)))
        return mp.atan2(k2 * lam1, (2 * k3 + k2) * r2 - k2 * r1) - beta_t

    lo, hi = mp.mpf(0), 2 * L - r1
    for _ in range(200):
        mid = (lo + hi) / 2
        if g(mid) > 0:
            lo = mid
        else:
            hi = mid
    return r1, (lo + hi) / 2
