"""First-principles Lagrangian dynamics of the class-2 mechanism, derived with sympy.

Model (the paper's Sect. 5.1, made precise):

- generalised coordinates ``q = (rho1, rho2, beta)``; node positions as in
  :mod:`tensegrity_core.class2.geometry` (A fixed, B and C on X, F on Y, E the apex of the
  isosceles triangle ACE, ``D = B + L (cos beta, sin beta)``);
- the four struts AE, BF, BD, CE (taken from :data:`geometry.MEMBERS`) are thin rods of
  mass ``m`` and length ``L``; kinetic energy ``1/2 m |v_c|^2 + 1/2 I omega^2`` with the
  centroid ``c`` at the midpoint, ``I = m L^2 / 12`` and ``omega = (r x rdot) / |r|^2`` for the
  strut vector ``r`` (no angle is introduced by hand);
- springs (:data:`geometry.SPRINGS`): linear, zero free length, ``U = 1/2 sum k_j L_j^2``;
  axial dampers, Rayleigh function ``R = 1/2 sum c_j Ldot_j^2``;
- actuators massless; a positive actuator force ``f_i`` is tensile, generalised force
  ``-f_i`` on ``rho_i`` (the paper's Eq. 48).

Equations of motion (Lagrange with Rayleigh dissipation)::

    M(q) qddot + C(q, qdot) + H(q) qdot + grad U(q) + (f1, f2, 0) = 0,
    M = d^2 T / dqdot^2,   C_i = sum_jk Gamma_ijk qdot_j qdot_k,
    Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i),   H = d^2 R / dqdot^2.

:func:`derive` builds all of this symbolically; :func:`check_derivation` checks the
internal consistencies (strut rigidity, Christoffel form == Euler-Lagrange form, the
hand-simplified closed forms used by the runtime == the derived expressions);
:func:`check_runtime` compares :mod:`tensegrity_core.class2.dynamics` with the
lambdified derivation at random states. ``python -m
studies.derivation.derive_dynamics`` runs both and prints the closed forms.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Final

import mpmath
import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from tensegrity_core.class2.geometry import MEMBERS, SPRINGS

PARAM_NAMES: Final = ("L", "m", "k1", "k2", "k3", "k4", "c1", "c2", "c3", "c4")


@dataclass(frozen=True)
class SymbolicDynamics:
    """The derived model; every field is a sympy object in the symbols below."""

    q: tuple[sp.Symbol, sp.Symbol, sp.Symbol]        # rho1, rho2, beta
    qd: tuple[sp.Symbol, sp.Symbol, sp.Symbol]       # their rates
    qdd: tuple[sp.Symbol, sp.Symbol, sp.Symbol]      # their accelerations
    p: dict[str, sp.Symbol]                          # PARAM_NAMES -> symbol
    f: tuple[sp.Symbol, sp.Symbol]                   # actuator forces f1, f2 (tensile > 0)
    nodes: dict[str, sp.Matrix]                      # node name -> 2x1 position
    T: sp.Expr                                       # kinetic energy
    M: sp.Matrix                                     # mass matrix, Hessian of T in qd
    gamma: list[list[list[sp.Expr]]]                 # Christoffel symbols Gamma[i][j][k]
    C: sp.Matrix                                     # velocity (Coriolis/centrifugal) terms
    H: sp.Matrix                                     # damping matrix, Hessian of R in qd
    U: sp.Expr                                       # potential energy
    grad_U: sp.Matrix                                # dU/dq
    f_e: sp.Matrix                                   # non-conservative generalised forces
    residual: sp.Matrix                              # M qdd + C + grad U - f_e (zero on solutions)


def _lambdas(q: Sequence[sp.Expr], L: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
    rho1, rho2, _ = q
    return sp.sqrt(4 * L**2 - (rho1 + rho2) ** 2), sp.sqrt(L**2 - rho1**2)


def _node_positions(q: Sequence[sp.Expr], L: sp.Expr) -> dict[str, sp.Matrix]:
    rho1, rho2, beta = q
    lam1, lam2 = _lambdas(q, L)
    return {
        "A": sp.Matrix([0, 0]),
        "B": sp.Matrix([rho1, 0]),
        "C": sp.Matrix([rho1 + rho2, 0]),
        "D": sp.Matrix([rho1 + L * sp.cos(beta), L * sp.sin(beta)]),
        "E": sp.Matrix([(rho1 + rho2) / 2, lam1 / 2]),
        "F": sp.Matrix([0, lam2]),
    }


def _rate(expr: sp.Expr, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> sp.Expr:
    """Time derivative of ``expr(q)`` along ``qdot = qd``."""
    return sum(sp.diff(expr, qi) * qdi for qi, qdi in zip(q, qd))


@lru_cache(maxsize=1)
def derive() -> SymbolicDynamics:
    """Derive T, M, Christoffel symbols, C, H, U and grad U from the model above."""
    q = sp.symbols("rho1 rho2 beta", real=True)
    qd = sp.symbols("rho1_d rho2_d beta_d", real=True)
    qdd = sp.symbols("rho1_dd rho2_dd beta_dd", real=True)
    p = {n: sp.Symbol(n, positive=True) for n in PARAM_NAMES}
    f = sp.symbols("f1 f2", real=True)
    L, m = p["L"], p["m"]
    nodes = _node_positions(q, L)

    T = sp.Integer(0)
    for member in MEMBERS:
        if member.kind != "strut":
            continue
        a, b = (nodes[n] for n in member.name)
        r = b - a
        r_d = r.applyfunc(lambda e: _rate(e, q, qd))
        centroid_d = ((a + b) / 2).applyfunc(lambda e: _rate(e, q, qd))
        omega = (r[0] * r_d[1] - r[1] * r_d[0]) / L**2   # |r| = L (checked in check_derivation)
        T += m * (centroid_d.dot(centroid_d)) / 2 + (m * L**2 / 12) * omega**2 / 2
    T = sp.expand(T)
    M = sp.hessian(T, qd).applyfunc(sp.simplify)

    n = 3
    gamma = [[[sp.simplify((sp.diff(M[i, j], q[k]) + sp.diff(M[i, k], q[j]) - sp.diff(M[j, k], q[i])) / 2)
               for k in range(n)] for j in range(n)] for i in range(n)]
    C = sp.Matrix([sum(gamma[i][j][k] * qd[j] * qd[k] for j in range(n) for k in range(n)) for i in range(n)])

    R = sp.Integer(0)
    U = sp.Integer(0)
    for member in SPRINGS:
        a, b = (nodes[nm] for nm in member.name)
        d = b - a
        length = sp.sqrt(d.dot(d))
        if member.damping is not None:
            R += p[member.damping] * _rate(length, q, qd) ** 2 / 2
        U += p[member.stiffness] * d.dot(d) / 2
    H = sp.hessian(R, qd)
    grad_U = sp.Matrix([sp.diff(U, qi) for qi in q])
    qd_vec = sp.Matrix(qd)
    f_e = -H * qd_vec - sp.Matrix([f[0], f[1], 0])
    residual = M * sp.Matrix(qdd) + C + grad_U - f_e
    return SymbolicDynamics(q, qd, qdd, p, f, nodes, T, M, gamma, C, H, sp.expand(U), grad_U, f_e, residual)


# ---------------------------------------------------------------------------------------
# The hand-simplified closed forms used by tensegrity_core.class2.dynamics, as sympy
# expressions in lambda1, lambda2, so that check_derivation can check them.
# ---------------------------------------------------------------------------------------

def closed_forms(sd: SymbolicDynamics, lambdas: tuple[sp.Expr, sp.Expr] | None = None) -> dict[str, sp.Expr]:
    """The runtime's closed forms (see ``docs/design/class2_dynamics.md``), keyed by name.

    ``lambdas``: expressions to use for (lambda1, lambda2); default their definitions
    (pass plain symbols to print the forms compactly).
    """
    rho1, rho2, beta = sd.q
    v1, v2, vb = sd.qd
    L, m = sd.p["L"], sd.p["m"]
    k1, k2, k3, k4 = (sd.p[f"k{i}"] for i in range(1, 5))
    lam1, lam2 = lambdas or _lambdas(sd.q, L)
    s = rho1 + rho2
    mu = m / 2 + 2 * m * L**2 / (3 * lam1**2)
    b_f = m * L**2 / (3 * lam2**2)
    kappa1 = 2 * m * L**2 * s / (3 * lam1**4)
    kappa2 = m * L**2 * rho1 / (3 * lam2**4)
    sd_ = v1 + v2
    return {
        "M11": m + mu + b_f,
        "M12": mu,
        "M22": mu,
        "M13": -m * L * sp.sin(beta) / 2,
        "M23": sp.Integer(0),
        "M33": m * L**2 / 3,
        "C1": kappa1 * sd_**2 + kappa2 * v1**2 - m * L * sp.cos(beta) * vb**2 / 2,
        "C2": kappa1 * sd_**2,
        "C3": sp.Integer(0),
        "dU/drho1": (-k1 * rho1 + k1 * (rho1 * lam1**2 + lam2**2 * s) / (2 * lam1 * lam2)
                     - (k2 + k4) * rho2 / 2 + k2 * L * sp.cos(beta) / 2
                     + k2 * L * s * sp.sin(beta) / (2 * lam1)),
        "dU/drho2": (k3 * rho2 - (k2 + k4) * rho1 / 2 - (k2 / 2 + k3) * L * sp.cos(beta)
                     + k1 * s * lam2 / (2 * lam1) + k2 * L * s * sp.sin(beta) / (2 * lam1)),
        "dU/dbeta": (L * sp.sin(beta) / 2 * ((k2 + 2 * k3) * rho2 - k2 * rho1)
                     - k2 * L * lam1 * sp.cos(beta) / 2),
        "L3^2": L**2 + rho2**2 - 2 * L * rho2 * sp.cos(beta),
        "L4^2": 2 * L**2 - rho1 * rho2 + (rho1 - rho2) * L * sp.cos(beta) - lam1 * L * sp.sin(beta),
        "L7^2": 2 * L**2 - rho1**2 - lam1 * lam2,
        "L8^2": L**2 - rho1 * rho2,
        "EF_dy": (rho2 - rho1) * (3 * rho1 + rho2) / (4 * (lam2 + lam1 / 2)),
    }


def derived_counterparts(sd: SymbolicDynamics) -> dict[str, sp.Expr]:
    """The derived expressions that :func:`closed_forms` claims to equal."""
    v = sd.nodes
    sq = {m.name: (v[m.name[1]] - v[m.name[0]]) for m in SPRINGS}
    out = {f"M{i + 1}{j + 1}": sd.M[i, j] for i in range(3) for j in range(i, 3)}
    out.update({f"C{i + 1}": sd.C[i] for i in range(3)})
    out.update({"dU/drho1": sd.grad_U[0], "dU/drho2": sd.grad_U[1], "dU/dbeta": sd.grad_U[2]})
    out.update({
        "L3^2": sq["CD"].dot(sq["CD"]),
        "L4^2": sq["DE"].dot(sq["DE"]),
        "L7^2": sq["EF"].dot(sq["EF"]),
        "L8^2": sq["BE"].dot(sq["BE"]),
        "EF_dy": sq["EF"][1],
    })
    return out


def random_state(rng: random.Random, *, margin: float = 0.05) -> dict[sp.Symbol, float]:
    """A random admissible point (parameters, q, qdot, qddot, f) as a sympy substitution."""
    sd = derive()
    L = rng.uniform(0.5, 2.0)
    rho1 = rng.uniform(-(1 - margin), 1 - margin) * L
    smax = (2 - margin) * L
    rho2 = rng.uniform(-smax - rho1, smax - rho1)
    vals = {sd.p["L"]: L, sd.p["m"]: rng.uniform(0.5, 3.0)}
    vals.update({sd.p[n]: rng.uniform(0.1, 3.0) for n in PARAM_NAMES[2:]})
    vals.update(dict(zip(sd.q, (rho1, rho2, rng.uniform(-math.pi, math.pi)))))
    vals.update({s: rng.gauss(0.0, 1.0) for s in (*sd.qd, *sd.qdd, *sd.f)})
    return vals


def _equal(a: sp.Expr, b: sp.Expr, rng: random.Random, *, points: int = 12) -> bool:
    """True if ``a == b`` identically: ``a - b`` within 1e-30 of ``1 + |b|`` at ``points``
    random admissible points (:func:`identical`, 40 significant digits; sympy's ``simplify``
    proves most such identities, but is not needed for the verdict and can be slow on
    unequal input)."""
    return identical(a, b, rng, points=points, digits=40, rel_tol=1e-30)


def identical(a: sp.Expr, b: sp.Expr, rng: random.Random, *, points: int, digits: int, rel_tol: float,
              margin: float = 0.05) -> bool:
    """True if ``|a - b| <= rel_tol (1 + |b|)`` at ``points`` states of :func:`random_state`.

    The states are floats, which mpmath holds exactly; ``a - b`` and ``b`` are evaluated in
    mpmath at ``digits + 20`` significant digits through ``lambdify`` (compiled once per
    expression; ``evalf(subs=...)`` walks the expression tree at every point: the appendix
    table of :mod:`paper_appendix_a` took 32 s that way, 3.5 s this way, compiling included).
    The 20 guard digits cover the cancellation between the terms of a difference that is
    zero; a wrong expression differs by far more than ``rel_tol``.
    """
    diff = a - b
    symbols = sorted(diff.free_symbols | b.free_symbols, key=str)
    f_diff = sp.lambdify(symbols, diff, "mpmath")
    f_ref = sp.lambdify(symbols, b, "mpmath")
    with mpmath.workdps(digits + 20):
        for _ in range(points):
            state = random_state(rng, margin=margin)
            args = [mpmath.mpf(state[s]) for s in symbols]
            if abs(f_diff(*args)) > rel_tol * (1 + abs(f_ref(*args))):
                return False
    return True


def euler_lagrange_residual(sd: SymbolicDynamics) -> sp.Matrix:
    """``d/dt dT/dqdot - dT/dq + dU/dq - f_e`` in q, qd, qdd, taken literally from ``T``: the
    time derivative of ``p_i = dT/dqdot_i (q, qdot)`` along a motion by the chain rule,
    ``dp_i/dt = sum_j dp_i/dq_j qdot_j + dp_i/dqdot_j qddot_j`` (what sympy's ``diff`` in
    ``t`` of ``T`` written with time functions computes, without the substitutions to and from
    them, which took ~80 % of :func:`check_derivation`'s time). Neither ``M`` nor the
    Christoffel symbols enter."""
    out = []
    for i, qdi in enumerate(sd.qd):
        p_i = sp.diff(sd.T, qdi)
        dp_dt = sum(sp.diff(p_i, qj) * qdj + sp.diff(p_i, qdj) * qddj for qj, qdj, qddj in zip(sd.q, sd.qd, sd.qdd))
        out.append(dp_dt - sp.diff(sd.T, sd.q[i]) + sd.grad_U[i] - sd.f_e[i])
    return sp.Matrix(out)


def check_derivation(seed: int = 0) -> dict[str, bool]:
    """Internal consistency of the derivation; every value must be True.

    - ``rigid:<strut>``: the strut's length is identically L;
    - ``euler_lagrange``: the Christoffel form equals Lagrange's equations taken literally;
    - ``H_is_sum_c_grad_grad``: H equals sum c_j grad(L_j) grad(L_j)^T;
    - ``closed:<name>``: each closed form of the runtime equals the derived expression.
    """
    sd = derive()
    rng = random.Random(seed)
    out: dict[str, bool] = {}
    L = sd.p["L"]
    for member in MEMBERS:
        if member.kind == "strut":
            a, b = (sd.nodes[n] for n in member.name)
            out[f"rigid:{member.name}"] = sp.simplify((b - a).dot(b - a) - L**2) == 0
    out["euler_lagrange"] = all(_equal(e, r, rng) for e, r in zip(euler_lagrange_residual(sd), sd.residual))
    h_sum = sp.zeros(3, 3)
    for member in SPRINGS:
        a, b = (sd.nodes[n] for n in member.name)
        length = sp.sqrt((b - a).dot(b - a))
        g = sp.Matrix([sp.diff(length, qi) for qi in sd.q])
        if member.damping is not None:
            h_sum += sd.p[member.damping] * g * g.T
    out["H_is_sum_c_grad_grad"] = all(_equal(h_sum[i, j], sd.H[i, j], rng) for i in range(3) for j in range(3))
    derived = derived_counterparts(sd)
    for name, expr in closed_forms(sd).items():
        out[f"closed:{name}"] = _equal(expr, derived[name], rng)
    return out


# ---------------------------------------------------------------------------------------
# Comparison with the runtime module at random points.
# ---------------------------------------------------------------------------------------

@lru_cache(maxsize=1)
def lambdified() -> dict[str, Callable[..., Any]]:
    """Numeric functions ``(params..., q..., qd..., f...) -> value`` of the derived model."""
    sd = derive()
    args = [sd.p[n] for n in PARAM_NAMES] + list(sd.q) + list(sd.qd) + list(sd.f)
    qdd = sd.M.LUsolve(-(sd.C + sd.H * sp.Matrix(sd.qd) + sd.grad_U + sp.Matrix([sd.f[0], sd.f[1], 0])))
    exprs = {"T": sd.T, "M": sd.M, "C": sd.C, "H": sd.H, "U": sd.U, "grad_U": sd.grad_U,
             "hess_U": sp.hessian(sd.U, sd.q), "f_e": sd.f_e, "qdd": qdd}
    return {k: sp.lambdify(args, v, "numpy") for k, v in exprs.items()}


def check_runtime(n_points: int = 50, seed: int = 1) -> dict[str, float]:
    """Largest relative error of each runtime function against the derivation.

    Points: random parameters, ``rho`` inside the domain (negative lengths included: the
    formulas are analytic there), random ``beta``, ``qdot``, forces.
    """
    from tensegrity_core.class2 import dynamics as dyn
    from tensegrity_core.class2.energy import potential_energy
    from tensegrity_core.class2.params import Class2Params

    fns = lambdified()
    sd = derive()
    rng = random.Random(seed)
    worst: dict[str, float] = {}

    def record(name: str, got: ArrayLike, want: ArrayLike) -> None:
        g, w = np.asarray(got, float), np.asarray(want, float)
        err = float(np.max(np.abs(g - w)) / (1.0 + np.max(np.abs(w))))
        worst[name] = max(worst.get(name, 0.0), err)

    for _ in range(n_points):
        st = random_state(rng)
        pv = {n: st[sd.p[n]] for n in PARAM_NAMES}
        params = Class2Params(**pv)
        q = np.array([st[s] for s in sd.q])
        qd = np.array([st[s] for s in sd.qd])
        f1, f2 = (st[s] for s in sd.f)
        args = [pv[n] for n in PARAM_NAMES] + list(q) + list(qd) + [f1, f2]
        record("kinetic_energy", dyn.kinetic_energy(q, qd, params), fns["T"](*args))
        record("mass_matrix", dyn.mass_matrix(q, params), fns["M"](*args))
        record("velocity_terms", dyn.velocity_terms(q, qd, params), np.ravel(fns["C"](*args)))
        record("damping_matrix", dyn.damping_matrix(q, params), fns["H"](*args))
        record("potential_energy", potential_energy(q, params), fns["U"](*args))
        record("potential_gradient", dyn.potential_gradient(q, params), np.ravel(fns["grad_U"](*args)))
        record("potential_hessian", dyn.potential_hessian(q, params), fns["hess_U"](*args))
        record("generalized_forces", dyn.generalized_forces(q, qd, f1, f2, params), np.ravel(fns["f_e"](*args)))
        record("acceleration", dyn.acceleration(q, qd, f1, f2, params), np.ravel(fns["qdd"](*args)))
        model = dyn.Class2Dynamics(params)
        rho1, rho2, beta = q.tolist()
        rho1_dot, rho2_dot, beta_dot = qd.tolist()
        record("Class2Dynamics.acceleration_scalar",
               model.acceleration_scalar(rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot, f1, f2),
               np.ravel(fns["qdd"](*args)))
    return worst


def main() -> int:
    sd = derive()
    print("Closed forms (lambda1 = sqrt(4L^2 - (rho1+rho2)^2), lambda2 = sqrt(L^2 - rho1^2)), "
          "each checked equal to the first-principles derivation (40-digit evaluation at random states):")
    for name, expr in closed_forms(sd, sp.symbols("lambda1 lambda2", positive=True)).items():
        print(f"  {name} = {expr}")
    print("\nConsistency checks:")
    checks = check_derivation()
    for name, ok in checks.items():
        print(f"  {'ok  ' if ok else 'FAIL'} {name}")
    print("\nRuntime vs derivation (max relative error over random states):")
    errors = check_runtime()
    for name, err in errors.items():
        print(f"  {name:40s} {err:.2e}")
    good = all(checks.values()) and max(errors.values()) < 1e-10
    print("\nall checks passed" if good else "\nSOME CHECKS FAILED")
    return 0 if good else 1


if __name__ == "__main__":
    raise SystemExit(main())
