"""The class-2 effects and their composition checked against independent computations.

Oracles: the first-principles sympy derivation of
:mod:`studies.derivation.derive_dynamics` (lambdified: M, C, H, grad U, its
Hessian, the accelerations; it derives them from the strut kinematics and the spring table,
independently of the kernel), central finite differences of energies and right-hand sides,
and a least-squares solution of all 24 Newton-Euler equations of the struts and nodes for
the member forces.
"""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.class2.dynamics import effects as fx
from tensegrity_core.class2.dynamics.inertia import Inertia
from tensegrity_core.class2.dynamics.kinematics import kinematics, kinematics_array
from tensegrity_core.class2.dynamics.limits import LAMBDA_MIN_REL
from tensegrity_core.class2.geometry import MEMBERS
from tensegrity_core.class2.params import PAPER_PARAMS
from tensegrity_core.sim import compile_scene
from tensegrity_core.sim.class2 import members

from .helpers import central_jacobian, class2_scene, random_states

PARAMS = PAPER_PARAMS.with_overrides(k1=1.3, k2=0.7, k3=2.1, k4=0.4, c1=0.02, c2=0.05, c3=0.03, c4=0.01, m=1.7)
GRAVITY = (1.2, -9.8, 3.0)
LOADS = {1: (1.0, 2.0, 3.0), 2: (0.4, 0.1, 0.0), 3: (0.3, -0.7, 0.0), 4: (1.1, 0.5, 0.0), 5: (0.2, -0.3, 0.0)}


def ctx(y):
    return kinematics(PARAMS.L, (y[0], y[1], y[2], y[3], y[4], y[5]), LAMBDA_MIN_REL * PARAMS.L)


def derived(name, params, y, f=(0.0, 0.0)):
    """The lambdified first-principles expression ``name`` at state ``y`` and forces ``f``."""
    from studies.derivation import derive_dynamics as dd

    args = [getattr(params, n) for n in dd.PARAM_NAMES] + list(y[:6]) + list(f)
    return np.asarray(dd.lambdified()[name](*args), dtype=float)


def test_springs_damping_and_inertia_compose_to_the_derived_equations_of_motion():
    scene = class2_scene()
    model = compile_scene(scene)
    fun = model.equations(model.initial_state()).fun
    for y in random_states(25, seed=1):
        t = 0.37
        f = (10 * y[0] * t, 10 * y[1] * t)           # the scene's f_i = 10 rho_i t
        expected = np.concatenate([y[3:6], np.ravel(derived("qdd", scene.model.params, y, f))])
        np.testing.assert_allclose(fun(t, y), expected, rtol=1e-11, atol=1e-11)


def test_inertia_terms_equal_the_derived_ones():
    inertia = Inertia(PARAMS)
    for y in random_states(10, seed=2):
        k = ctx(y)
        np.testing.assert_allclose(inertia.mass_matrix(k), derived("M", PARAMS, y), rtol=1e-13)
        np.testing.assert_allclose(inertia.velocity_terms(k), np.ravel(derived("C", PARAMS, y)), atol=1e-12)
        assert inertia.kinetic_energy(k) == pytest.approx(float(derived("T", PARAMS, y)), rel=1e-13)


@pytest.mark.parametrize("effect", [fx.Springs(PARAMS), fx.Gravity(PARAMS, GRAVITY), fx.Loads(PARAMS, LOADS)],
                         ids=["springs", "gravity", "loads"])
def test_conservative_forces_are_minus_the_gradient_of_their_energy(effect):
    for y in random_states(10, seed=3):
        grad = central_jacobian(lambda q: np.array([effect.energy(ctx((*q, 0, 0, 0)))]), y[:3])[0]
        np.testing.assert_allclose(effect.force(ctx(y)), -grad, atol=1e-8)


def test_spring_forces_and_stiffness_equal_the_derived_gradient_and_hessian():
    springs = fx.Springs(PARAMS)
    for y in random_states(10, seed=4):
        np.testing.assert_allclose(springs.force(ctx(y)), -np.ravel(derived("grad_U", PARAMS, y)), atol=1e-13)
        np.testing.assert_allclose(fx.stiffness_matrix(springs.stiffness(ctx(y))), derived("hess_U", PARAMS, y),
                                   atol=1e-12)


@pytest.mark.parametrize("effect", [fx.Springs(PARAMS), fx.Gravity(PARAMS, GRAVITY), fx.Loads(PARAMS, LOADS),
                                    fx.Damping(PARAMS)], ids=["springs", "gravity", "loads", "damping"])
def test_force_jacobians_match_finite_differences(effect):
    for y in random_states(8, seed=5):
        dq, dqd = effect.jacobian(ctx(y))
        fd = central_jacobian(lambda z: np.array(effect.force(ctx(z))), y[:6])
        np.testing.assert_allclose(dq, fd[:, :3], atol=1e-7)
        np.testing.assert_allclose(dqd, fd[:, 3:], atol=1e-7)


def test_damping_force_is_minus_the_derived_damping_matrix_times_the_rates():
    damping = fx.Damping(PARAMS)
    for y in random_states(8, seed=6):
        H = derived("H", PARAMS, y)
        np.testing.assert_allclose(damping.force(ctx(y)), -H @ y[3:6], atol=1e-13)
        np.testing.assert_allclose(damping.matrix(ctx(y)), H, atol=1e-13)


def test_springs_and_dampers_in_one_pass_equal_their_sum():
    """Listed together, springs and dampers are evaluated as one term: the same force."""
    terms = fx.force_terms((fx.Springs(PARAMS), fx.Damping(PARAMS)))
    assert len(terms) == 1
    for y in random_states(8, seed=9):
        k = ctx(y)
        np.testing.assert_allclose(terms[0](k), np.add(fx.Springs(PARAMS).force(k), fx.Damping(PARAMS).force(k)),
                                   rtol=1e-14, atol=1e-14)


ALL_EFFECTS = ["inertia", "springs", "damping", {"gravity": {"vector": list(GRAVITY)}},
               {"loads": {"D": [0.3, -0.7, 0], "E": [1.1, 0.5, 0]}}, {"actuator_lag": {"tau": 0.05}},
               {"actuator_compliance": {"stiffness": 1000.0, "drive_damping": 2.0}}, "fold_limit"]


@pytest.mark.parametrize("mode", [frozenset(), frozenset({0}), frozenset({1}), frozenset({0, 1})])
def test_the_analytic_jacobian_matches_finite_differences_in_every_contact_mode(mode):
    scene = class2_scene(effects=ALL_EFFECTS, inputs={"f1": {"law": "proportional", "gain": 10.0},
                                                       "f2": {"law": "ramp", "from": 0, "to": 2, "t1": 3}},
                         initial={"q": [0.5, 0.6, 0.8]})      # the springs cannot hold this weight at rest
    model = compile_scene(scene)
    segment = model.equations(model.initial_state()).with_mode(mode)
    for y in random_states(5, seed=7, extra=4):
        for i in mode:
            y[i] = y[3 + i] = 0.0
        fd = central_jacobian(lambda z: segment.fun(1.3, z), y)
        np.testing.assert_allclose(segment.jac(1.3, y), fd, rtol=1e-6, atol=1e-6)


def _newton_euler_lstsq(params, q, qd, qdd, T, gravity=None):
    """All 24 Newton-Euler equations (4 struts x 3, 6 massless nodes x 2) in the 16 strut end
    forces and 5 support reactions, solved by least squares: (mid-span strut forces, residual)."""
    L, m = params.L, params.m
    k = kinematics_array(L, q[None], qd[None])
    P = members.node_positions(L, k)[0]
    acc = members.node_accelerations(L, k, qdd[None])[0]
    g = np.zeros(2) if gravity is None else np.asarray(gravity[:2])
    struts = [(i, *mm.nodes) for i, mm in enumerate(MEMBERS) if mm.kind == "strut"]
    A = np.zeros((24, 21))
    b = np.zeros(24)
    for s, (_, a, bb) in enumerate(struts):
        c = 0.5 * (P[a] + P[bb])
        ra, rb = P[a] - c, P[bb] - c
        A[3 * s, 4 * s] = A[3 * s, 4 * s + 2] = 1
        A[3 * s + 1, 4 * s + 1] = A[3 * s + 1, 4 * s + 3] = 1
        b[3 * s:3 * s + 2] = m * (0.5 * (acc[a] + acc[bb]) - g)
        A[3 * s + 2, 4 * s:4 * s + 4] = [-ra[1], ra[0], -rb[1], rb[0]]
        rel = P[bb] - P[a]
        ddr = acc[bb] - acc[a]
        b[3 * s + 2] = m * L**2 / 12 * (rel[0] * ddr[1] - rel[1] * ddr[0]) / L**2
        for end, node in ((0, a), (1, bb)):
            A[12 + 2 * node, 4 * s + 2 * end] = A[12 + 2 * node + 1, 4 * s + 2 * end + 1] = -1
    for j, (node, axis) in enumerate([(0, 0), (0, 1), (1, 1), (2, 1), (5, 0)]):
        A[12 + 2 * node + axis, 16 + j] = 1
    springs = {"CD": params.k3, "DE": params.k2, "EF": params.k1, "BE": params.k4}
    for i, mm in enumerate(MEMBERS):
        a, bb = mm.nodes
        if mm.kind == "strut":
            continue
        if mm.kind == "actuator":
            f = T[i] * np.array([1.0, 0.0])
        else:
            f = springs[mm.name] * (P[bb] - P[a])
        b[12 + 2 * a:14 + 2 * a] -= f
        b[12 + 2 * bb:14 + 2 * bb] += f
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    forces = []
    for s, (_, a, bb) in enumerate(struts):
        u = (P[bb] - P[a]) / L
        forces.append(0.5 * (-x[4 * s:4 * s + 2] @ u + x[4 * s + 2:4 * s + 4] @ u))
    return np.array(forces), np.linalg.norm(A @ x - b)


@pytest.mark.parametrize("gravity", [None, (0.0, -9.81, 0.0)], ids=["horizontal", "vertical"])
def test_strut_forces_solve_all_newton_euler_equations(gravity):
    """The closed-form strut forces equal the least-squares solution of every Newton-Euler
    equation, whose residual vanishes: the Lagrangian accelerations satisfy Newton-Euler."""
    effects = ["inertia", "springs"] + ([{"gravity": {"vector": list(gravity)}}] if gravity else [])
    scene = class2_scene(effects=effects, initial={"q": [0.5, 0.6, 0.8]})   # any start: states are drawn below
    params = scene.model.params
    model = compile_scene(scene)
    segment = model.equations(model.initial_state())
    for y in random_states(10, seed=8):
        t = 0.8
        qdd, _ = segment.accelerations(t, y)
        T = np.array([10 * y[0] * t, 10 * y[1] * t])
        ours = members.member_forces(params, y[:3], y[3:6], qdd, T[None], springs=True, damping=False,
                                     gravity=gravity)[0]
        strut_forces, residual = _newton_euler_lstsq(params, y[:3], y[3:6], qdd, T, gravity)
        assert residual < 1e-10
        np.testing.assert_allclose(ours[[4, 5, 8, 9]], strut_forces, rtol=1e-9, atol=1e-9)
