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


@st.composite
def extreme_parameter_sets(draw):
    """Strut length and the kinematic springs k2, k3 over six decades (1e-3 to 1e3, the ends
    drawn on purpose): the ratio (2 k3 + k2) / k2 that amplifies dD/drho2 reaches 2e6."""
    k = edged(1e-3, 1e3).map(lambda v: v if v > 0.0 else 1e-3)
    return PAPER_PARAMS.with_overrides(L=draw(edged(1e-3, 1e3).filter(lambda v: v > 0.0)), k2=draw(k), k3=draw(k))


@st.composite
def edge_configurations(draw, params=PAPER_PARAMS):
    """(rho1, rho2) [m] in the configuration domain of ``params`` with the edges drawn on
    purpose: rho1 in [0, L], rho2 a fraction of [0, 2L - rho1], both fractions :func:`edged`."""
    L = params.L
    rho1 = L * draw(edged(0.0, 1.0))
    top = 2.0 * L - rho1
    rho2 = top * draw(edged(0.0, 1.0))
    while rho1 + rho2 > 2.0 * L:
        rho2 = math.nextafter(rho2, 0.0)
    return rho1, rho2


#: Signed offsets (units of L) of a target from W's boundary along the outward normal.
BOUNDARY_OFFSETS = (0.0, 1e-16, -1e-16, 1e-13, -1e-13, 5e-13, -5e-13, 2e-12, -2e-12, 1e-9, -1e-9, 1e-6, -1e-6,
                    1e-3, -1e-3)


@st.composite
def boundary_targets(draw, params=PAPER_PARAMS):
    """``(x, y)`` [m] near the boundary of the workspace W of ``params`` (the quarter circles
    about A and about (L, 0), the top y = L and the bottom y = 0), displaced along the outward
    normal by one of :data:`BOUNDARY_OFFSETS` (positive: outside)."""
    L = params.L
    piece = draw(st.integers(0, 3))
    t = draw(edged(0.0, 1.0))
    off = draw(st.sampled_from(BOUNDARY_OFFSETS))
    b = 0.5 * math.pi * t
    if piece == 0:      # arc about A: outside is towards A
        return L * math.cos(b) * (1.0 - off), L * math.sin(b) * (1.0 - off)
    if piece == 1:      # top segment
        return t * L, L * (1.0 + off)
    if piece == 2:      # arc about (L, 0): outside is away from it
        return L + L * math.cos(b) * (1.0 + off), L * math.sin(b) * (1.0 + off)
    return L + t * L, -off * L
