"""The paper's printed dynamics (Eq. 46, Eqs. 48-50, Appendix A), transcribed literally.

Ji, Li & Lin, Sect. 5 and Appendix A: the kinetic energy ``T`` (Eq. 46 with Eq. 47), the
damping forces (Eqs. 48-50, one coefficient ``c``) and the entries of ``M, F, G, H, W`` of
Eq. (51), ``M qddot + F qdot_p + G qdot_q + H qdot + W = 0`` with
``qdot_p = (rho1_dot^2, rho2_dot^2, beta_dot^2)`` and
``qdot_q = (rho1_dot rho2_dot, rho1_dot beta_dot, rho2_dot beta_dot)``.

Every entry is transcribed as printed, typos included, so that it can be evaluated against
the first-principles derivation of :mod:`derive_dynamics`. The damping entries (A.6-A.14)
name lengths ``L_1..L_4`` and coefficients ``c_1..c_4``; two readings are provided:

- ``literal``: ``L_i`` as defined by Eqs. (5-8) (``L_1 = rho1``, ``L_2 = rho2``, ``L_3 = |CD|``,
  ``L_4 = |DE|``) and ``c_i`` as in Sect. 5.1 (``c_i`` with ``k_i``);
- ``relabelled``: the reading under which most terms make sense (inferred from the shape
  of each term): ``(c1, L1) -> EF (c1, L7)``, ``(c2, L2) -> BE (c4, L8)``,
  ``(c3, L3) -> DE (c2, L4)``, ``(c4, L4) -> CD (c3, L3)``.

``python -m studies.derivation.paper_appendix_a`` prints the comparison table.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Final, TypeAlias

import numpy as np
import sympy as sp
from numpy.typing import NDArray

from studies.derivation.derive_dynamics import (
    PARAM_NAMES,
    SymbolicDynamics,
    derive,
    identical,
)

READINGS: Final = ("literal", "relabelled")


@dataclass(frozen=True)
class PrintedModel:
    """The printed quantities as sympy expressions in the symbols of :func:`derive`."""

    T: sp.Expr
    M: sp.Matrix
    F: sp.Matrix
    G: sp.Matrix
    H: dict[str, sp.Matrix]        # reading -> matrix
    W: sp.Matrix
    f_e_single_c: sp.Matrix        # Eqs. 48-50 with one coefficient c (symbol "c")
    c: sp.Symbol


def _spring_lengths(sd: SymbolicDynamics) -> dict[str, sp.Expr]:
    nodes = sd.nodes

    def length(a: str, b: str) -> sp.Expr:
        d = nodes[b] - nodes[a]
        return sp.sqrt(d.dot(d))
    return {"L3": length("C", "D"), "L4": length("D", "E"), "L7": length("E", "F"), "L8": length("B", "E")}


@lru_cache(maxsize=1)
def printed() -> PrintedModel:
    sd = derive()
    rho1, rho2, beta = sd.q
    v1, v2, vb = sd.qd
    p = sd.p
    L, m = p["L"], p["m"]
    k1, k2, k3, k4 = (p[f"k{i}"] for i in range(1, 5))
    f1, f2 = sd.f
    s = rho1 + rho2
    lam1 = sp.sqrt(4 * L**2 - s**2)
    lam2 = sp.sqrt(L**2 - rho1**2)
    sb, cb = sp.sin(beta), sp.cos(beta)
    I = m * L**2 / 12

    # Eq. (46) with Eq. (1) for cos(alpha) and Eq. (47) for alpha_dot.
    cos_a = s / (2 * L)
    sin_a = sp.sqrt(1 - cos_a**2)
    alpha_d = -1 / sp.sqrt(1 - cos_a**2) * (v1 + v2) / (2 * L)
    T = (m / 8 * ((v1 + v2 - L * sin_a * alpha_d) ** 2 + (cos_a**2 + 1) * L**2 * alpha_d**2
                  + (4 + L**2 / (L**2 - rho1**2)) * v1**2 + L**2 * vb**2 - 4 * L * v1 * vb * sb)
         + I / 2 * (2 * alpha_d**2 + vb**2 + v1**2 / (L**2 - rho1**2)))

    # (A.1)-(A.2)
    m11 = 25 * m / 16 + m * (20 * L**2 + 3 * s**2) / (48 * lam1**2) + m * L**2 / (3 * lam2**2)
    m12 = 9 * m / 16 + m * (20 * L**2 + 3 * s**2) / (48 * lam1**2)
    m13 = -m * L * sb / 2
    M = sp.Matrix([[m11, m12, m13], [m12, m12, 0], [m13, 0, m * L**2 / 3]])

    # (A.3)-(A.5)
    br = (10 * L**2 - lam1 * s) / lam1**5
    f12 = m * L**2 / 6 * br
    F = sp.Matrix([[m * L**2 / 6 * (br + 2 * rho1 / lam2**4), f12, -m * L * cb / 2],
                   [f12, f12, 0], [0, 0, 0]])
    g11 = m * L**2 / 3 * br
    G = sp.Matrix([[g11, 0, 0], [g11, 0, 0], [0, 0, 0]])

    # (A.16)-(A.18); rho2^2 and k2 k4 exactly as printed.
    W = sp.Matrix([
        k2 * L * cb / 2 - k1 * rho1 - k1 * (rho1 * lam1**2 - lam2**2 * (rho1 + rho2**2)) / (lam1 * lam2)
        - (k2 + k4) * rho2 / 2 + k2 * L * s * sb / (2 * lam1) + f1,
        k3 * rho2 - k2 * k4 * rho1 / 2 - (k2 / 2 + k3) * L * cb
        + 2 * k1 * rho2 * lam2**2 * (rho1 + rho2**2) / (lam1 * lam2) + k2 * L * s * sb / (2 * lam1) + f2,
        L * sb / 2 * ((k2 + 2 * k3) * rho2 - k2 * rho1) - k2 * L * cb * lam1 / 2,
    ])

    lengths = _spring_lengths(sd)
    H = {
        "literal": _printed_H(sd, {"c1": p["c1"], "c2": p["c2"], "c3": p["c3"], "c4": p["c4"],
                                   "L1": rho1, "L2": rho2, "L3": lengths["L3"], "L4": lengths["L4"]}),
        "relabelled": _printed_H(sd, {"c1": p["c1"], "c2": p["c4"], "c3": p["c2"], "c4": p["c3"],
                                      "L1": lengths["L7"], "L2": lengths["L8"], "L3": lengths["L4"],
                                      "L4": lengths["L3"]}),
    }

    c = sp.Symbol("c", positive=True)
    qd = sp.Matrix(sd.qd)
    fe = []
    for i, qi in enumerate(sd.q):
        term = 0
        for Lj in lengths.values():
            Lj_dot = sum(sp.diff(Lj, qk) * vk for qk, vk in zip(sd.q, qd))
            term += -c * Lj_dot * sp.diff(Lj, qi)
        fe.append(term - (f1, f2, 0)[i])
    return PrintedModel(T, M, F, G, H, W, sp.Matrix(fe), c)


def _printed_H(sd: SymbolicDynamics, n: Mapping[str, sp.Expr]) -> sp.Matrix:
    """(A.6)-(A.14) with the symbols named in ``n`` for ``c_1..c_4`` and ``L_1..L_4``."""
    rho1, rho2, beta = sd.q
    L, m = sd.p["L"], sd.p["m"]
    c1, c2, c3, c4 = n["c1"], n["c2"], n["c3"], n["c4"]
    L1, L2, L3, L4 = n["L1"], n["L2"], n["L3"], n["L4"]
    s = rho1 + rho2
    lam1 = sp.sqrt(4 * L**2 - s**2)
    lam2 = sp.sqrt(L**2 - rho1**2)
    sb, cb = sp.sin(beta), sp.cos(beta)
    b_a = L * cb + L * s * sb / lam1                         # [L cos b + L s sin b / lam1]
    b_b = (L * cb - rho2) / 2 + L * s / (2 * lam1)           # [(L cos b - rho2)/2 + L s/(2 lam1)]
    b_c = (-L * cb - rho1) / 2 + L * s / (2 * lam1)          # [(-L cos b - rho1)/2 + L s/(2 lam1)]
    b_d = (-L * cb - rho1) / 2 + L * s * sb / (2 * lam1)     # [(-L cos b - rho1)/2 + L s sin b/(2 lam1)]
    b_e = L * (rho2 - rho1) * sb / 2 - L * lam1 * cb / 2     # [L (rho2 - rho1) sin b/2 - L lam1 cos b/2]
    g7 = lam2 * s / (2 * lam1) + lam1 * rho1 / (2 * lam2) - rho1
    h11 = (25 * m / 16 + c1 / L1**2 * (rho1 * lam2**2 * s / (2 * lam1 * lam2) - rho1) * g7
           + c2 * rho2**2 / (4 * L2**2) + c3 / L3**2 * b_a * b_b)
    h12 = (9 * m / 16 + c1 / L1**2 * ((rho1 * lam1**2 - lam2**2 * s) / (2 * lam1 * lam2) - rho1)
           * lam2 * s / (2 * lam1) + c2 * rho1 * rho2 / (4 * L2**2) + c3 / L3**2 * b_a * b_c)
    h13 = c3 / L3**2 * b_a * (-rho1 * L * sb - L * lam1 * cb / 2)
    h21 = (9 * m / 16 + c1 / L1**2 * lam2 * s / (2 * lam1) * g7 + c2 * rho1 * rho2 / (4 * L2**2)
           + c3 / L3**2 * b_d * b_b)
    h22 = (9 * m / 16 + c1 * s**2 * lam2**2 / (4 * L1**2 * lam1**2) + c2 * rho1**2 / (4 * L2**2)
           + c4 * rho2**2 * L**2 * sb * cb / L4**2 * c3 / L3**2 * b_d * b_e)
    h23 = c3 / (2 * L3**2) * b_d * b_b + c4 * rho2**2 * L**2 * sb**2 / L4**2
    h31 = c3 / L3**2 * b_e * b_b
    h32 = c3 / L3**2 * b_e * b_c + c4 * rho2 * L * sb / L4**2 * (rho2 - L * cb)
    h33 = c3 / L3**2 * b_e**2 + c4 * rho2**2 * L**2 * sb**2 / L4**2
    return sp.Matrix([[h11, h12, h13], [h21, h22, h23], [h31, h32, h33]])


def correct_model() -> dict[str, sp.Expr]:
    """The derived counterparts: ``F``, ``G`` split of the Christoffel terms and ``W``."""
    sd = derive()
    v1, v2, vb = sd.qd
    quad = [v1**2, v2**2, vb**2]
    cross = [(v1 * v2), (v1 * vb), (v2 * vb)]
    F = sp.zeros(3, 3)
    G = sp.zeros(3, 3)
    for i in range(3):
        poly = sp.Poly(sp.expand(sd.C[i]), *sd.qd)
        for j, mono in enumerate(quad):
            F[i, j] = poly.coeff_monomial(mono)
        for j, mono in enumerate(cross):
            G[i, j] = poly.coeff_monomial(mono)
    W = sd.grad_U + sp.Matrix([sd.f[0], sd.f[1], 0])
    return {"T": sd.T, "M": sd.M, "F": F, "G": G, "H": sd.H, "W": W}


@dataclass(frozen=True)
class EntryCheck:
    entry: str                      # e.g. "H12 (A.7)"
    reading: str                    # "" or one of READINGS
    equal: bool                     # identical to the derivation (30-digit check at random points)
    printed: tuple[float, ...]      # values at REFERENCE_POINTS
    correct: tuple[float, ...]      # derived values at REFERENCE_POINTS


_EQS: Final = {"M": ("A.1", "A.1", "A.2", "A.2", "A.2", "A.2", "A.2", "A.2", "A.2"),
        "F": ("A.3", "A.3", "A.4", "A.4", "A.4", "A.4", "A.4", "A.4", "A.4"),
        "G": ("A.5",) * 9,
        "H": ("A.6", "A.7", "A.8", "A.9", "A.10", "A.11", "A.12", "A.13", "A.14"),
        "W": ("A.16", "A.17", "A.18")}

#: Where the table shows values: the paper's initial state and a state near the fold,
#: both with a velocity and actuator forces; L = 1, m = 2, k = 1, distinct c_j.
REFERENCE_POINTS: Final = (
    dict(q=(0.7, 0.7, 0.8), qd=(0.3, -0.2, 0.5), f=(1.0, 2.0)),
    dict(q=(0.2, 0.3, 1.2), qd=(-0.4, 0.1, 0.6), f=(0.5, -1.0)),
)
REFERENCE_PARAMS: Final = dict(L=1.0, m=2.0, k1=1.0, k2=1.0, k3=1.0, k4=1.0, c1=0.01, c2=0.02, c3=0.03, c4=0.04)


def _reference_subs(sd: SymbolicDynamics, point: Mapping[str, Sequence[float]]) -> dict[sp.Symbol, float]:
    subs = {sd.p[n]: v for n, v in REFERENCE_PARAMS.items()}
    subs.update(dict(zip(sd.q, point["q"])))
    subs.update(dict(zip(sd.qd, point["qd"])))
    subs.update(dict(zip(sd.f, point["f"])))
    return subs


def _same(a: sp.Expr, b: sp.Expr, rng: random.Random, points: int = 6) -> bool:
    """``a == b`` identically, to 30 digits at ``points`` random states (margin 0.2 from the
    workspace boundary)."""
    return identical(a, b, rng, points=points, digits=30, rel_tol=1e-20, margin=0.2)


def compare(seed: int = 0) -> list[EntryCheck]:
    """Every printed entry against the derivation (same random points for every entry)."""
    sd = derive()
    pm = printed()
    good = correct_model()
    refs = [_reference_subs(sd, pt) for pt in REFERENCE_POINTS]
    rows: list[EntryCheck] = []

    def add(entry: str, reading: str, a: sp.Expr, b: sp.Expr) -> None:
        rng = random.Random(seed)
        rows.append(EntryCheck(entry, reading, _same(a, b, rng), tuple(float(a.evalf(subs=r)) for r in refs),
                               tuple(float(b.evalf(subs=r)) for r in refs)))

    add("T (Eq. 46)", "", pm.T, good["T"])
    for name in ("M", "F", "G"):
        mat = getattr(pm, name)
        for idx in range(9):
            i, j = divmod(idx, 3)
            add(f"{name}{i + 1}{j + 1} ({_EQS[name][idx]})", "", mat[i, j], good[name][i, j])
    for reading in READINGS:
        for idx in range(9):
            i, j = divmod(idx, 3)
            add(f"H{i + 1}{j + 1} ({_EQS['H'][idx]})", reading, pm.H[reading][i, j], good["H"][i, j])
    for i in range(3):
        add(f"W{i + 1} ({_EQS['W'][i]})", "", pm.W[i], good["W"][i])
    c = sd.p["c1"]                      # one coefficient for every spring, as Eqs. 48-50 assume
    c_subs = {sd.p[f"c{i}"]: c for i in range(2, 5)}
    for i in range(3):
        add(f"f_e{i + 1} (Eq. {48 + i}, all c_j = c)", "", pm.f_e_single_c[i].subs(pm.c, c),
            sd.f_e[i].subs(c_subs))
    return rows


#: ``(params, q, qd, f1, f2) -> qddot`` (3,) of a model.
Acceleration: TypeAlias = Callable[[Mapping[str, float], Sequence[float], Sequence[float], float, float],
                                   NDArray[np.float64]]


@lru_cache(maxsize=2)
def printed_eom(reading: str = "literal") -> Acceleration:
    """Numeric ``qddot`` of the printed Eq. (51): ``(params dict, q, qd, f1, f2) -> (3,)``.

    For experiments only (what would a simulation of the printed equations do?).
    """
    sd = derive()
    pm = printed()
    v1, v2, vb = sd.qd
    qp = sp.Matrix([v1**2, v2**2, vb**2])
    qq = sp.Matrix([v1 * v2, v1 * vb, v2 * vb])
    rest = pm.F * qp + pm.G * qq + pm.H[reading] * sp.Matrix(sd.qd) + pm.W
    args = [sd.p[n] for n in PARAM_NAMES] + list(sd.q) + list(sd.qd) + list(sd.f)
    m_fn = sp.lambdify(args, pm.M, "numpy")
    r_fn = sp.lambdify(args, rest, "numpy")

    def qdd(params: Mapping[str, float], q: Sequence[float], qd: Sequence[float], f1: float,
            f2: float) -> NDArray[np.float64]:
        a = [params[n] for n in PARAM_NAMES] + list(q) + list(qd) + [f1, f2]
        return np.linalg.solve(np.asarray(m_fn(*a), float), -np.ravel(np.asarray(r_fn(*a), float)))

    return qdd


def markdown_table(rows: list[EntryCheck]) -> str:
    head = " | ".join(f"printed P{k + 1} | correct P{k + 1}" for k in range(len(REFERENCE_POINTS)))
    out = [f"| entry | reading | {head} | verdict |",
           "|---|---|" + "---:|" * (2 * len(REFERENCE_POINTS)) + "---|"]
    for r in rows:
        verdict = "agrees" if r.equal else "**wrong**"
        vals = " | ".join(f"{p:.6g} | {c:.6g}" for p, c in zip(r.printed, r.correct))
        out.append(f"| {r.entry} | {r.reading or '-'} | {vals} | {verdict} |")
    return "\n".join(out)


def main() -> int:
    for k, pt in enumerate(REFERENCE_POINTS):
        print(f"P{k + 1}: q = {pt['q']}, qdot = {pt['qd']}, (f1, f2) = {pt['f']}")
    print("parameters:", ", ".join(f"{n} = {v:g}" for n, v in REFERENCE_PARAMS.items()), "\n")
    print(markdown_table(compare()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
