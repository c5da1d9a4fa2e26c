"""Stiffness of the class-2 mechanism along the nodal coordinates (the paper's Sect. 4).

Conventions. Nodal coordinates ``X = [Ax, Ay, Bx, By, ..., Fx, Fy]`` [m] (Eq. 26 order); the
supports (Eq. 29) fix ``Ax, Ay, By, Cy, Fx``, leaving ``x_r = [Bx, Cx, Dx, Dy, Ex, Ey, Fy]``
(Eq. 30 without its duplicated ``a_Ex``). Member forces ``t`` [N] are tensions (positive
pulls the two nodes together). The equilibrium matrix ``A`` (12 x 10) has, in column i of
member P-Q, the unit vector ``(P - Q) / l_i`` at P's rows and its negative at Q's rows, so
``A t = f`` balances the external nodal forces ``f`` [N] (Guest 2006; the paper's Eq. 28
with its sign erratum for n10 corrected, docs/class2.md). ``A^T`` is the compatibility
matrix: ``dl = A^T dX``.

Three independent routes to the 7 x 7 tangent stiffness ``K = dF_r / dx_r`` [N/m]:

(a) :func:`stiffness_matrix_paper` -- the paper's procedure ``K = A_r G^ A_r^T + S_r``
    (Eqs. 36-40): ``A_r`` (Eq. 32), modified axial stiffnesses ``g_i - t_i / l_i`` (Eq. 36,
    g = ka for the actuators, kb for the struts, k for the springs), stress matrix
    ``S_r = (Omega kron I_2)_r`` (Eqs. 37-39, rows AND columns of the supports removed);
(b) :func:`stiffness_matrix_assembled` -- element tangent stiffnesses
    ``g n n^T + (t / l)(I - n n^T)`` assembled over all six nodes (12 x 12), supports deleted;
(c) :func:`stiffness_matrix_energy_fd` -- central second differences of the total potential
    energy (springs ``k l^2 / 2``; struts and actuators ``g (l - l0)^2 / 2`` with rest
    lengths ``l0 = l - t / g`` that make the current forces elastic; minus the work ``f Fy``).

Member forces (:func:`member_forces`): the paper's Eq. (35) cannot be evaluated as printed,
because ``A_0 = [a1 a2 a5 a6 a8 a9 a10]`` is singular (rank 6): the rotation of D about B
changes only the lengths of members 3 and 4, so it is a left null vector of ``A_0``; and
the framework AB, BC, AE, BE, CE on the X axis carries a self-stress, a right null vector.
The physically consistent reading used here: every spring force from Hooke's law (zero free
length, ``t = k l``), the six actuator and strut forces from the seven equilibrium equations
by least squares. The residual of those equations is the component along the rotation of D,
``-dU/dbeta / L``: zero exactly when beta is the FKP equilibrium.

The pre-stress force ``f`` [N] acts on node F along +Y (Eq. 44).

Definiteness. ``K`` is the tangent stiffness of the framework whose actuators and struts
are elastic (axial stiffnesses ``ka``, ``kb``); the mechanism's energy
:func:`~tensegrity_core.class2.energy.potential_energy` treats them as rigid, leaving the
one coordinate beta at locked actuators. The two agree in the limit ``ka, kb -> infinity``:
then the motions that stretch a rigid member cost infinite energy and ``K(f = 0)`` is
positive definite exactly when ``d2U/dbeta2 > 0``. For finite ``ka, kb`` ``K(0)`` can have a
negative eigenvalue where ``d2U/dbeta2 > 0``, and it is real (the second difference of the
member energies along its eigenvector is negative): near the folded point ``s = rho1 + rho2
-> 0`` the compressed struts AE and CE are nearly parallel, a sideways motion ``d`` of E
stretches them only by about ``s d / (2L)``, so what holds E sideways is the springs'
stiffness minus the struts' geometric stiffness ``(|t_AE| + |t_CE|) / L`` plus only ``kb (s /
2L)^2`` and the actuators' compliance. E.g. ``k2 = k4 = 428 N/m``, ``ka = 1e4 N/m``, ``kb =
4.3e5 N/m`` (other parameters the paper's) at ``rho1 = rho2 = 1e-6 L``: smallest eigenvalue
-3.98 N/m while ``d2U/dbeta2 = 428 N m/rad``; the framework buckles sideways at E, the
rigid-strut mechanism does not. At the paper's parameters ``K(0)`` is positive definite over
the configuration domain (tested on draws down to 1e-6 L from its edges).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.geometry import MEMBERS, check_actuator_lengths, node_positions
from tensegrity_core.class2.kinematics import as_real, forward_kinematics
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import SingularityError

#: Names of the reduced coordinates x_r (the paper's Eq. 30 without the duplicate a_Ex).
COORDINATES: Final = ("Bx", "Cx", "Dx", "Dy", "Ex", "Ey", "Fy")
#: Indices of x_r in the 12 nodal coordinates [Ax, Ay, Bx, By, ..., Fx, Fy].
FREE: Final = np.array([2, 4, 6, 7, 8, 9, 11])
#: Indices of the supported coordinates Ax, Ay, By, Cy, Fx (Eq. 29).
SUPPORTED: Final = np.array([0, 1, 3, 5, 10])

_SPRINGS: Final = np.array([m.number - 1 for m in MEMBERS if m.kind == "spring"])          # 3, 4, 7, 8
_RIGID: Final = np.array([m.number - 1 for m in MEMBERS if m.kind != "spring"])            # 1, 2, 5, 6, 9, 10
_I: Final = np.array([m.nodes[0] for m in MEMBERS])
_J: Final = np.array([m.nodes[1] for m in MEMBERS])


def axial_stiffnesses(params: Class2Params) -> NDArray[np.float64]:
    """Axial stiffness g_i [N/m] of members 1..10 (Eq. 36): ka, kb or the spring's k."""
    return np.array([getattr(params, m.stiffness) for m in MEMBERS], dtype=np.float64)


def _configuration(rho1: float, rho2: float, beta: float | None, params: Class2Params) -> tuple[float, float, float]:
    rho1 = as_real("rho1", rho1)
    rho2 = as_real("rho2", rho2)
    L = params.L
    check_actuator_lengths(rho1, rho2, L)
    for kind, value, what in (
        ("rho1_zero", rho1, "actuator AB has zero length (rho1 = 0)"),
        ("rho2_zero", rho2, "actuator BC has zero length (rho2 = 0)"),
        ("lambda2", L - rho1, "rho1 = L: F reaches A and strut BF lies on the X axis"),
        ("lambda1", 2.0 * L - rho1 - rho2, "rho1 + rho2 = 2L: struts AE and CE are collinear"),
    ):
        if value <= 1e-12 * L:
            raise SingularityError(
                f"the stiffness matrix does not exist at rho1 = {rho1:g} m, rho2 = {rho2:g} m: "
                f"{what} (distance {value:.3g} m)", kind=kind, distance=value, limit=1e-12 * L)
    if beta is None:
        beta = forward_kinematics(rho1, rho2, params).beta
    else:
        beta = as_real("beta", beta)
    return rho1, rho2, beta


def _geometry(rho1: float, rho2: float, beta: float, params: Class2Params
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Node positions (6, 2), member lengths (10,) and unit vectors n_i = (P - Q)/l (10, 2)."""
    p = node_positions((rho1, rho2, beta), params)
    vec = p[_I] - p[_J]
    lengths = np.linalg.norm(vec, axis=1)
    return p, lengths, vec / lengths[:, None]


def equilibrium_matrix(rho1: float, rho2: float, beta: float | None = None,
                       params: Class2Params = PAPER_PARAMS) -> NDArray[np.float64]:
    """The 12 x 10 equilibrium matrix A (Eq. 28, corrected): ``A t = f``."""
    rho1, rho2, beta = _configuration(rho1, rho2, beta, params)
    _, _, n = _geometry(rho1, rho2, beta, params)
    return _assemble_A(n)


def _assemble_A(n: NDArray[np.float64]) -> NDArray[np.float64]:
    A = np.zeros((12, 10))
    cols = np.arange(10)
    for k in range(2):
        A[2 * _I + k, cols] = n[:, k]
        A[2 * _J + k, cols] = -n[:, k]
    return A


def member_forces(rho1: float, rho2: float, f: float = 0.0, beta: float | None = None,
                  params: Class2Params = PAPER_PARAMS) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tensions ``t`` [N] of members 1..10 and the equilibrium residual ``A_r t - f_r`` [N] (7,).

    Springs by Hooke's law, the rest by least squares on the seven reduced equilibrium
    equations with ``f_r = [0, 0, 0, 0, 0, 0, f]`` (Eq. 44). See the module docstring for why
    Eq. (35) as printed cannot be used.
    """
    rho1, rho2, beta = _configuration(rho1, rho2, beta, params)
    f = as_real("f", f)
    _, lengths, n = _geometry(rho1, rho2, beta, params)
    return _forces(_assemble_A(n)[FREE], lengths, f, params)


def _forces(A_r: NDArray[np.float64], lengths: NDArray[np.float64], f: float,
            params: Class2Params) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    t = np.zeros(10)
    t[_SPRINGS] = axial_stiffnesses(params)[_SPRINGS] * lengths[_SPRINGS]
    f_r = np.zeros(7)
    f_r[-1] = f
    rhs = f_r - A_r[:, _SPRINGS] @ t[_SPRINGS]
    t[_RIGID] = np.linalg.lstsq(A_r[:, _RIGID], rhs, rcond=None)[0]
    return t, A_r @ t - f_r


def _stress_matrix(t_hat: NDArray[np.float64]) -> NDArray[np.float64]:
    """Omega kron I_2 (12 x 12), Eqs. (23)-(24)."""
    omega = np.zeros((6, 6))
    for i, j, th in zip(_I, _J, t_hat):
        omega[i, j] -= th
        omega[j, i] -= th
        omega[i, i] += th
        omega[j, j] += th
    return np.kron(omega, np.eye(2))  # type: ignore[return-value]  # numpy's stubs: kron of float64 is floating[Any]


@dataclass(frozen=True)
class StiffnessResult:
    """Stiffness of the mechanism at one configuration and pre-stress force.

    Attributes
    ----------
    rho1, rho2 : actuator lengths [m]; beta : angle of BD [rad] (the FKP equilibrium unless
        given); f : force on F along +Y [N] (Eq. 44).
    coordinates : names of x_r, the order of every 7-vector and of K.
    K : 7 x 7 stiffness matrix [N/m] (Eq. 40, route (a)).
    K_i : stiffness along each coordinate [N/m], ``K_ii - u_i K_ri^-1 v_i`` (Eq. 43).
    cond_K_r : 2-norm condition number of K_ri for each i (inf if singular).
    t : member tensions [N], members 1..10; lengths : member lengths [m].
    g_hat : modified axial stiffnesses ``g_i - t_i / l_i`` [N/m] (Eq. 36).
    equilibrium_residual : ``max |A_r t - f_r|`` [N]; ~1e-15 at the FKP equilibrium.
    min_eigenvalue : smallest eigenvalue of K [N/m]. Where it is negative the framework
        (elastic actuators and struts) is unstable, and the K_i are Schur complements of an
        unstable equilibrium, not stiffnesses a load could measure, even when all are
        positive (one negative eigenvalue can leave every ``(K^-1)_ii`` positive).
    """

    rho1: float
    rho2: float
    beta: float
    f: float
    coordinates: tuple[str, ...]
    K: NDArray[np.float64]
    K_i: NDArray[np.float64]
    cond_K_r: NDArray[np.float64]
    t: NDArray[np.float64]
    lengths: NDArray[np.float64]
    g_hat: NDArray[np.float64]
    equilibrium_residual: float
    min_eigenvalue: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "rho1": self.rho1, "rho2": self.rho2, "beta": self.beta, "f": self.f,
            "coordinates": list(self.coordinates), "K": self.K, "K_i": dict(zip(self.coordinates, self.K_i)),
            "cond_K_r": dict(zip(self.coordinates, self.cond_K_r)),
            "member_forces": {m.label: float(v) for m, v in zip(MEMBERS, self.t)},
            "g_hat": {m.label: float(v) for m, v in zip(MEMBERS, self.g_hat)},
            "equilibrium_residual": self.equilibrium_residual, "min_eigenvalue": self.min_eigenvalue,
        }


def stiffness_matrix_paper(rho1: float, rho2: float, f: float = 0.0, beta: float | None = None,
                           params: Class2Params = PAPER_PARAMS) -> NDArray[np.float64]:
    """Route (a): ``K = A_r G^ A_r^T + S_r`` [N/m] (Eqs. 36-40), 7 x 7 over :data:`COORDINATES`."""
    return _paper_procedure(*_configuration(rho1, rho2, beta, params), as_real("f", f), params)[0]


def _paper_procedure(
    rho1: float, rho2: float, beta: float, f: float, params: Class2Params
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(K, t, lengths, g_hat, residual)`` of the paper's procedure at a validated configuration."""
    _, lengths, n = _geometry(rho1, rho2, beta, params)
    A_r = _assemble_A(n)[FREE]
    t, residual = _forces(A_r, lengths, f, params)
    t_hat = t / lengths
    g_hat = axial_stiffnesses(params) - t_hat
    S_r = _stress_matrix(t_hat)[np.ix_(FREE, FREE)]
    return A_r @ np.diag(g_hat) @ A_r.T + S_r, t, lengths, g_hat, residual


def stiffness_matrix_assembled(rho1: float, rho2: float, f: float = 0.0, beta: float | None = None,
                               params: Class2Params = PAPER_PARAMS) -> NDArray[np.float64]:
    """Route (b): element tangent stiffnesses ``g n n^T + (t/l)(I - n n^T)`` summed over the
    nodes (12 x 12), supports deleted; same member forces as :func:`member_forces`."""
    rho1, rho2, beta = _configuration(rho1, rho2, beta, params)
    t, _ = member_forces(rho1, rho2, f, beta, params)
    _, lengths, n = _geometry(rho1, rho2, beta, params)
    g = axial_stiffnesses(params)
    K = np.zeros((12, 12))
    for i in range(10):
        nn = np.outer(n[i], n[i])
        ke = g[i] * nn + (t[i] / lengths[i]) * (np.eye(2) - nn)
        P, Q = 2 * _I[i], 2 * _J[i]
        K[P:P + 2, P:P + 2] += ke
        K[Q:Q + 2, Q:Q + 2] += ke
        K[P:P + 2, Q:Q + 2] -= ke
        K[Q:Q + 2, P:P + 2] -= ke
    K_r: NDArray[np.float64] = K[np.ix_(FREE, FREE)]
    return K_r


def total_potential_energy(X: NDArray[np.float64], rest: NDArray[np.float64], f: float,
                           params: Class2Params) -> float:
    """Total potential energy [J] of nodal coordinates X (12,): springs ``k l^2 / 2``, struts and
    actuators ``g (l - rest)^2 / 2``, minus the work ``f Fy`` of the load on F."""
    return float(_energies(np.asarray(X, dtype=float)[None], rest, f, params)[0])


def _energies(X: NDArray[np.float64], rest: NDArray[np.float64], f: float,
              params: Class2Params) -> NDArray[np.float64]:
    """:func:`total_potential_energy` [J] (B,) of B sets of nodal coordinates X (B, 12) at once."""
    p = X.reshape(len(X), 6, 2)
    lengths = np.linalg.norm(p[:, _I] - p[:, _J], axis=2)
    g = axial_stiffnesses(params)
    stretch = np.where(np.isin(np.arange(10), _SPRINGS), lengths, lengths - rest)
    energies: NDArray[np.float64] = 0.5 * np.sum(g * stretch**2, axis=1) - f * X[:, 11]
    return energies


def stiffness_matrix_energy_fd(rho1: float, rho2: float, f: float = 0.0, beta: float | None = None,
                               params: Class2Params = PAPER_PARAMS, *,
                               step: float | None = None) -> NDArray[np.float64]:
    """Route (c): Hessian of :func:`total_potential_energy` over x_r by central differences.

    Rest lengths ``l0 = l - t / g`` make the elastic forces equal the member forces of
    :func:`member_forces`. ``step`` defaults to ``1e-4 L``: the truncation error is
    ``O(step^2 g / l^2)`` and the rounding error ``O(eps E / step^2)``.
    """
    rho1, rho2, beta = _configuration(rho1, rho2, beta, params)
    f = as_real("f", f)
    t, _ = member_forces(rho1, rho2, f, beta, params)
    p, lengths, _ = _geometry(rho1, rho2, beta, params)
    g = axial_stiffnesses(params)
    rest = lengths - t / g
    X0 = p.reshape(-1)
    h = 1e-4 * params.L if step is None else float(step)

    # the 4 x 28 displaced coordinate sets of the central differences, their energies in one
    # batch: one energy per call spent ~10 ms of CPU per Hessian in numpy's per-call overhead, ~1 ms so
    i, j = np.triu_indices(7)
    X = np.repeat(X0[None], 4 * len(i), axis=0).reshape(4, len(i), 12)
    for k, (si, sj) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
        X[k, np.arange(len(i)), FREE[i]] += si * h
        X[k, np.arange(len(i)), FREE[j]] += sj * h
    E = _energies(X.reshape(-1, 12), rest, f, params).reshape(4, len(i))
    H = np.empty((7, 7))
    H[i, j] = H[j, i] = (E[0] - E[1] - E[2] + E[3]) / (4.0 * h * h)
    return H


def stiffness_along_coordinates(rho1: float, rho2: float, f: float = 0.0,
                                params: Class2Params = PAPER_PARAMS, *, beta: float | None = None) -> StiffnessResult:
    """The paper's stiffness analysis at ``(rho1, rho2)`` [m] with pre-stress force ``f`` [N].

    beta defaults to the FKP equilibrium (then ``equilibrium_residual`` ~ 0); any other beta
    gives the stiffness of a configuration that is not in equilibrium, and the residual says
    by how much. Raises :class:`SingularityError` where the matrix does not exist (a zero
    actuator length, ``rho1 = L``, ``rho1 + rho2 = 2L``) and :class:`DomainError` outside the
    configuration domain; :class:`SingularityError` (kind ``"K_r_singular"``) when some
    ``K_ri`` is singular to working precision, where Eq. (43) is undefined.
    """
    rho1, rho2, beta = _configuration(rho1, rho2, beta, params)
    f = as_real("f", f)
    K, t, lengths, g_hat, residual = _paper_procedure(rho1, rho2, beta, f, params)
    K_i, cond = _along_coordinates(K)
    return StiffnessResult(rho1, rho2, beta, f, COORDINATES, K, K_i, cond, t, lengths, g_hat,
                           float(np.max(np.abs(residual))), float(np.linalg.eigvalsh(K)[0]))


def _along_coordinates(K: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eq. (43) for every coordinate: ``K_ii - u_i K_ri^-1 v_i`` and ``cond(K_ri)``."""
    m = K.shape[0]
    K_i = np.empty(m)
    cond = np.empty(m)
    for i in range(m):
        keep = np.arange(m) != i
        K_ri = K[np.ix_(keep, keep)]
        cond[i] = np.linalg.cond(K_ri)
        if not math.isfinite(cond[i]) or cond[i] > 1.0 / np.finfo(float).eps:
            raise SingularityError(
                f"K with row and column {COORDINATES[i]} removed is singular (cond = {cond[i]:.3g}); "
                f"the stiffness along {COORDINATES[i]} (Eq. 43) is undefined",
                kind="K_r_singular", distance=0.0)
        K_i[i] = K[i, i] - K[i, keep] @ np.linalg.solve(K_ri, K[keep, i])
    return K_i, cond


def stiffness_sweep(rho1: float, rho2: float, forces: ArrayLike,
                    params: Class2Params = PAPER_PARAMS) -> dict[str, Any]:
    """``K_i(f)`` over the forces ``forces`` [N] (the paper's Fig. 2): a dict with ``f`` (m,),
    ``K_i`` (m, 7), ``cond_K_r`` (m, 7), ``min_eigenvalue`` (m,) [N/m] (negative: the K_i of
    that row belong to an unstable framework), ``coordinates`` and the configuration."""
    fs = np.asarray(forces, dtype=float)
    rows = [stiffness_along_coordinates(rho1, rho2, float(fv), params) for fv in fs]
    return {
        "rho1": rows[0].rho1 if rows else float(rho1), "rho2": rows[0].rho2 if rows else float(rho2),
        "beta": rows[0].beta if rows else math.nan, "coordinates": COORDINATES, "f": fs,
        "K_i": np.array([r.K_i for r in rows]).reshape(len(fs), 7),
        "cond_K_r": np.array([r.cond_K_r for r in rows]).reshape(len(fs), 7),
        "min_eigenvalue": np.array([r.min_eigenvalue for r in rows]),
    }



def critical_forces(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> NDArray[np.float64]:
    """Real forces f [N] on F (+Y) at which ``det K(f) = 0``, ascending.

    The member forces, hence ``K``, are affine in f: ``K(f) = K(0) + f (K(1) - K(0))``, so
    these are the finite real eigenvalues of the pencil ``(K(0), -(K(1) - K(0)))``. Between
    two consecutive critical forces ``K(f)`` keeps one inertia (``det K`` does not vanish);
    between the two around 0 it is that of ``K(0)``, which is positive definite at the
    paper's parameters but need not be for finite ``ka, kb`` near the folded point (module
    docstring, "Definiteness"). At a critical force the stiffnesses K_i pass through zero or
    have a pole.
    """
    from scipy import linalg

    K0 = stiffness_matrix_paper(rho1, rho2, 0.0, None, params)
    K1 = stiffness_matrix_paper(rho1, rho2, 1.0, None, params) - K0
    ev = linalg.eigvals(K0, -K1)
    real = ev[np.isfinite(ev) & (np.abs(ev.imag) <= 1e-9 * np.maximum(1.0, np.abs(ev.real)))].real
    return np.sort(real[np.abs(real) < 1e12])
