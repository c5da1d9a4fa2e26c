"""Hypothesis strategies shared by the class-2 kinematics tests (configurations, params)."""

from __future__ import annotations

import math

from hypothesis import strategies as st

from tensegrity_core.class2 import PAPER_PARAMS

unit = st.floats(0.0, 1.0, allow_nan=False)


def edged(lo: float, hi: float):
    """Floats in ``[lo, hi]`` with half the draws on the ends or just inside them (one ulp,
    1e-12, 1e-9 and 1e-6 of the width): the boundary of a range is drawn on purpose."""
    width = hi - lo
    edges = [lo, hi, math.nextafter(lo, hi), math.nextafter(hi, lo)]
    for f in (1e-12, 1e-9, 1e-6):
        edges += [lo + f * width, hi - f * width]
    return st.one_of(st.sampled_from(edges), st.floats(lo, hi))


@st.composite
def configurations(draw, margin: float = 0.0, params=PAPER_PARAMS):
    """(rho1, rho2) in the configuration domain, at least ``margin`` (in units of L) inside."""
    L = params.L
    rho1 = L * (margin + (1.0 - 2.0 * margin) * draw(unit))
    top = 2.0 * L - rho1 - margin * L * math.sqrt(2.0)
    rho2 = margin * L + max(0.0, top - margin * L) * draw(unit)
    return rho1, min(rho2, 2.0 * L - rho1)


@st.composite
def parameter_sets(draw):
    """Spring stiffnesses and strut length over two decades (the kinematics depend on k2, k3, L)."""
    k = st.floats(0.1, 10.0)
    return PAPER_PARAMS.with_overrides(L=draw(st.floats(0.2, 5.0)), k1=draw(k), k2=draw(k),
                                       k3=draw(k), k4=draw(k))


def scaled(rho, params):
    """A unit-L configuration scaled to ``params.L``, kept inside ``rho1 + rho2 <= 2L`` after rounding."""
    r1 = min(rho[0] * params.L, params.L)
    r2 = min(rho[1] * params.L, 2.0 * params.L - r1)
    while r1 + r2 > 2.0 * params.L:
        r2 = math.nextafter(r2, 0.0)
    return r1, r2
