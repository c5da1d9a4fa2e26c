"""Form-finding: convergence, stability, failure reporting, methods, options."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation
from threadpoolctl import threadpool_info, threadpool_limits

from tensegrity_core.errors import ConvergenceError
from tensegrity_core.general import (
    METHODS,
    Configuration,
    RigidBody,
    Structure,
    StructureError,
    form_find,
    load_example,
    out_of_balance,
    prism_tower,
)
from tests.general.paper_oracle import euler_matrix


def prism(twist_deg=20.0, ratio=0.9):
    """Triangular prism: 3 bars, 9 strings, free (six rigid-body modes)."""
    ang = np.deg2rad([0, 120, 240])
    bottom = np.c_[np.cos(ang), np.sin(ang), np.zeros(3)]
    top = np.c_[np.cos(ang + np.deg2rad(twist_deg)), np.sin(ang + np.deg2rad(twist_deg)), np.ones(3)]
    members = [[0, 4], [1, 5], [2, 3], [0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3], [0, 3], [1, 4], [2, 5]]
    return Structure.from_arrays(np.vstack([bottom, top]), np.array(members), EA=[1e5] * 3 + [1e3] * 9,
                                 kinds=["bar"] * 3 + ["string"] * 9, rest_length_ratio=[1.0] * 3 + [ratio] * 9)


def test_prism_reaches_the_known_twist_and_force_pattern():
    """The stable regular 3-prism has the top turned 150 deg relative to the bottom where
    bar i joins bottom i to top i+1 (here: 30 deg between node labels), equal forces in
    each group, strings in tension, bars in compression."""
    r = form_find(prism(), tol=1e-12)
    assert r.success and r.stable and r.rigid_body_modes == 6
    bottom, top = r.nodes[:3] - r.nodes[:3].mean(axis=0), r.nodes[3:] - r.nodes[3:].mean(axis=0)
    axis = r.nodes[3:].mean(axis=0) - r.nodes[:3].mean(axis=0)
    axis /= np.linalg.norm(axis)
    twist = np.arctan2(np.cross(bottom, top) @ axis, np.sum(bottom * top, axis=1))   # about the axis
    np.testing.assert_allclose(np.rad2deg(twist), 30.0, atol=1e-7)
    t = r.member_forces
    for group in (t[:3], t[3:6], t[6:9], t[9:]):
        np.testing.assert_allclose(group, group[0], rtol=1e-8)
    assert np.all(t[:3] < 0) and np.all(t[3:] > 0)
    assert r.residual <= 1e-12 and r.residual_norm <= 1e-9


def test_dense_and_sparse_newton_agree():
    s = load_example("spine_s")
    dense = form_find(s, linear_solver="dense")
    sparse = form_find(s, linear_solver="sparse")
    assert dense.success and sparse.success
    np.testing.assert_allclose(sparse.nodes, dense.nodes, atol=1e-9 * np.abs(dense.nodes).max())
    np.testing.assert_allclose(sparse.min_eigenvalue, dense.min_eigenvalue, rtol=1e-6)


@pytest.mark.parametrize("name", ["t_bar", "spherical_tetrahedron"])
def test_dynamic_relaxation_reaches_the_same_equilibrium(name):
    s = load_example(name)
    newton = form_find(s)
    relax = form_find(s, method="dynamic_relaxation")
    assert relax.success, relax.message
    assert relax.residual <= 1e-10 and relax.iterations > 3 * newton.iterations
    assert relax.residual_norm <= 1e-9 * s.EA.max()
    if s.layout.fixed_mask.any():
        np.testing.assert_allclose(relax.nodes, newton.nodes, atol=1e-8)
    else:     # free structure: compare the shape (all pairwise distances)
        d = lambda x: np.linalg.norm(x[:, None] - x[None], axis=-1)  # noqa: E731
        np.testing.assert_allclose(d(relax.nodes), d(newton.nodes), atol=1e-8)


def independent_minimum(s: Structure, x0: np.ndarray) -> np.ndarray:
    """Minimise the potential energy with a general optimiser over free coordinates and,
    per body, centre + rotation vector (scipy's Rotation), energy written out here."""
    lay = s.layout
    free = lay.free_index >= 0
    bodies = [list(b.nodes) for b in s.bodies if not b.fixed]
    ref = [s.nodes[b] - s.nodes[b].mean(axis=0) for b in bodies]

    def coords(z):
        x = x0.copy()
        x[free] = z[:free.sum()]
        for k, b in enumerate(bodies):
            c, th = z[free.sum() + 6 * k:][:3], z[free.sum() + 6 * k + 3:][:3]
            x[b] = c + ref[k] @ Rotation.from_rotvec(th).as_matrix().T
        return x

    def energy(z):
        x = coords(z)
        l = np.linalg.norm(x[s.members[:, 1]] - x[s.members[:, 0]], axis=1)
        e = np.where(s.is_string & (l < s.rest_lengths), 0.0, s.EA / s.rest_lengths * 0.5 * (l - s.rest_lengths) ** 2)
        return e.sum() - np.sum(s.loads * x)

    z0 = np.concatenate([x0[free]] + [np.r_[x0[b].mean(axis=0), 0, 0, 0] for b in bodies])
    res = minimize(energy, z0, method="BFGS", options={"gtol": 1e-9 * s.EA.max(), "maxiter": 5000})
    return coords(res.x)


@pytest.mark.parametrize("name", ["t_bar", "patio_shade"])
def test_equilibrium_agrees_with_an_independent_energy_minimiser(name):
    s = load_example(name)
    r = form_find(s)
    assert r.success
    np.testing.assert_allclose(independent_minimum(s, s.nodes), r.nodes, atol=1e-5)


@pytest.mark.parametrize("label, Q0", [
    ("Euler-singular attitude at the solution", euler_matrix([0.3, np.pi / 2, -0.4]).T),
    ("turned 120 deg about y, through beta = 90 deg", Rotation.from_rotvec([0, 2 * np.pi / 3, 0]).as_matrix()),
    ("turned 150 deg about y", Rotation.from_rotvec([0, np.deg2rad(150), 0]).as_matrix()),
])
def test_a_body_turned_through_the_paper_singular_attitude_form_finds(platform, label, Q0):
    """The body is redrawn so that reaching the equilibrium takes the rotation Q0 (Euler
    beta = 90 deg at, or on the way to, the solution): same equilibrium as before."""
    ref = form_find(platform)
    c = ref.configuration.centres[0]
    drawn = platform.nodes.copy()
    drawn[:4] = c + (ref.nodes[:4] - c) @ Q0
    r = form_find(platform.with_nodes(drawn))
    assert r.success, (label, r.message)
    np.testing.assert_allclose(r.nodes, ref.nodes, atol=1e-9)
    np.testing.assert_allclose(r.configuration.rotations[0], Q0, atol=1e-9)


def test_an_unstable_equilibrium_is_a_failure_not_a_result():
    """A node between two pinned nodes on two compressed collinear bars: the straight start
    is an equilibrium (zero residual) but a saddle. Without escapes that is reported as a
    failure; with them the bars relax to their rest length off the line, and the remaining
    zero-energy swing about the axis through the two pins is reported as a rigid-body mode."""
    nodes = np.array([[-1, 0, 0], [0, 0, 0], [1, 0, 0.0]])
    s = Structure.from_arrays(nodes, [[0, 1], [1, 2]], EA=100.0, rest_length_ratio=1.2, kinds="bar",
                              pinned=[True, False, True])
    stuck = form_find(s, max_escapes=0)
    assert stuck.iterations == 0 and stuck.residual == 0.0
    assert not stuck.success and stuck.status == 3 and not stuck.stable
    assert "unstable equilibrium" in stuck.message and stuck.min_eigenvalue < 0
    with pytest.raises(ConvergenceError, match="unstable equilibrium") as info:
        form_find(s, max_escapes=0, strict=True)
    assert info.value.result.status == 3
    escaped = form_find(s)
    assert escaped.success and escaped.rigid_body_modes == 1
    np.testing.assert_allclose(np.linalg.norm(escaped.nodes[1, 1:]), np.sqrt(1.2**2 - 1), rtol=1e-9)


def test_a_neutral_equilibrium_is_a_failure():
    """Two stress-free collinear strings hold a node with zero lateral stiffness."""
    nodes = np.array([[-1, 0, 0], [0, 0, 0], [1, 0, 0.0]])
    s = Structure.from_arrays(nodes, [[0, 1], [1, 2]], EA=100.0, pinned=[True, False, True])
    r = form_find(s)
    assert not r.success and r.status == 4 and "unstiffened mechanism" in r.message


def test_a_saddle_is_left_along_its_unstable_mode():
    """The same bars inside a stabilising string net: the straight start is a saddle, the
    search leaves it and ends stable."""
    nodes = np.array([[-1, 0, 0], [0, 0, 0], [1, 0, 0.0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    members = [[0, 1], [1, 2], [1, 3], [1, 4], [1, 5], [1, 6]]
    s = Structure.from_arrays(nodes, members, EA=[100, 100, 1, 1, 1, 1], kinds=["bar"] * 2 + ["string"] * 4,
                              rest_lengths=[1.2, 1.2, 1.0, 1.0, 1.0, 1.0], pinned=[True, False] + [True] * 5)
    r = form_find(s)
    assert r.success and r.stable
    assert np.linalg.norm(r.nodes[1, 1:]) > 0.1                   # left the straight line


def test_no_equilibrium_reports_failure_without_raising():
    """A free body pulled by an unbalanced load has no equilibrium."""
    tri = np.array([[1, 0, 0], [-0.5, 0.8, 0], [-0.5, -0.8, 0.0]])
    s = Structure.from_arrays(np.vstack([tri, tri + [0, 0, 1]]), [[0, 3], [1, 4], [2, 5]], EA=1.0,
                              bodies=[RigidBody("a", (0, 1, 2)), RigidBody("b", (3, 4, 5))],
                              loads=[[0, 0, 0]] * 3 + [[1, 0, 0]] * 3)
    r = form_find(s, max_iter=50)
    assert not r.success and r.status in (1, 2, 7) and r.residual >= 1.0
    assert np.isfinite(r.nodes).all() and np.isfinite(r.residual)


def test_runaway_is_reported_as_divergence():
    """Two free nodes on a string, one pushed by a load: the whole structure runs away
    (the potential falls without bound). form_find says so before iterating; dynamic
    relaxation itself, run past that check, follows the runaway and says so too."""
    from tensegrity_core.general.relaxation import dynamic_relaxation
    from tensegrity_core.general.statics import as_configuration

    nodes = np.array([[0, 0, 0], [0, 0, 1.0]])
    s = Structure.from_arrays(nodes, [[0, 1]], EA=10.0, loads=[[0, 0, 0], [1.0, 0, 0]])
    r = form_find(s, method="dynamic_relaxation")
    assert not r.success and r.status == 7 and r.iterations == 0
    assert "no equilibrium exists" in r.message and "[1, 0, 0] N" in r.message
    r = dynamic_relaxation(s, as_configuration(s, None), tol=1e-9)
    assert not r.success and r.status == 7 and "diverged" in r.message


def test_callback_receives_each_iteration_and_can_stop():
    s = load_example("spine_c")
    seen = []
    r = form_find(s, callback=seen.append)
    assert [i.iteration for i in seen] == list(range(1, r.iterations + 1))
    assert seen[-1].residual == pytest.approx(r.residual) and all(i.shift > 0 for i in seen)
    assert [h["iteration"] for h in r.history] == [i.iteration for i in seen]
    stopped = form_find(s, callback=lambda info: info.iteration >= 2)
    assert stopped.status == 5 and stopped.iterations == 2 and not stopped.success


def test_restart_from_a_result_and_from_coordinates():
    s = load_example("tensegrity_table")
    r = form_find(s)
    again = form_find(s, x0=r.configuration)
    assert again.iterations == 0 and again.success
    shorter = s.with_rest_lengths(s.rest_lengths * 0.95)
    r2 = form_find(shorter, x0=r.nodes)
    assert r2.success and r2.configuration.structure is shorter
    assert out_of_balance(shorter, r2.configuration).residual <= 1e-10 * s.EA.max()


def test_options_are_validated():
    s = load_example("t_bar")
    with pytest.raises(StructureError, match="unknown form-finding method 'magic'"):
        form_find(s, method="magic")
    for tol, why in ((-1.0, "must be > 0"), (math.nan, "must be finite"), ("1e-9", "must be a number")):
        with pytest.raises(StructureError, match=rf"tol \(relative residual\) {why}"):
            form_find(s, tol=tol)
    for max_iter in (-1, 2.5, math.nan, "10", True):
        with pytest.raises(StructureError, match="max_iter must be an integer >= 0"):
            form_find(s, max_iter=max_iter)
    with pytest.raises(StructureError, match="unknown option 'max_iterations' of form-finding method 'newton'"):
        form_find(s, max_iterations=10)
    with pytest.raises(StructureError, match="unknown option 'shift' of form-finding method 'dynamic_relaxation'"):
        form_find(s, method="dr", shift=0.1)
    with pytest.raises(StructureError, match="linear_solver"):
        form_find(s, linear_solver="cholmod")
    assert set(METHODS) == {"newton", "dynamic_relaxation"}
    assert form_find(load_example("tensegrity_table"), method="dr").method == "dynamic_relaxation"


def test_result_dict_lists_nodes_and_members_in_description_order():
    s = load_example("patio_shade")
    d = form_find(s).to_dict()
    assert list(d["nodes"]) == list(s.node_names) and list(d["members"]) == list(s.member_names)
    assert d["success"] and d["members"]["s1"]["force"] > 0 and not d["members"]["s1"]["slack"]
    assert d["members"]["s1"]["force_density"] == pytest.approx(d["members"]["s1"]["force"] / d["members"]["s1"]["length"])


def test_configuration_from_another_topology_is_rejected():
    a, b = load_example("t_bar"), load_example("patio_shade")
    with pytest.raises(StructureError, match="other nodes"):
        form_find(a, x0=Configuration.initial(b))


def _blas_threads() -> set[int]:
    return {pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"}


def test_dense_newton_runs_blas_on_one_thread_and_gives_the_threads_back():
    """Dense algebra of a few hundred unknowns pays a second BLAS thread's hand-overs and, on
    a busy machine, its spinning (docs/design/general.md: 7x the CPU per step at 234 DOF): the
    dense Newton iterations run on one thread, seen from the callback, and the process's
    setting is back afterwards; sparse Newton leaves it alone."""
    tower = prism_tower(2)
    s = tower.with_rest_lengths(np.where(tower.is_string, 0.99, 1.0) * tower.rest_lengths)
    with threadpool_limits(2, user_api="blas"):
        assert _blas_threads() == {2}
        for solver, inside in (("dense", {1}), ("sparse", {2})):
            seen: list[set[int]] = []
            r = form_find(s, linear_solver=solver, callback=lambda info, seen=seen: seen.append(_blas_threads()))
            assert r.success and seen and all(threads == inside for threads in seen)
            assert _blas_threads() == {2}
