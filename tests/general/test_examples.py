"""The paper's examples (Sect. 5.2), from the shipped files and the generators."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.general import (
    example_names,
    form_find,
    load_example,
    modal_analysis,
    modes,
    rest_length_path,
    spherical_tensegrity,
    t_bar,
    tensegrity_spine,
    tensegrity_table,
)


@pytest.mark.parametrize("name, make", [
    ("t_bar", lambda: t_bar(0.8)),
    ("tensegrity_table", tensegrity_table),
    ("spine_c", lambda: tensegrity_spine(10, shape="C")),
    ("spine_s", lambda: tensegrity_spine(10, shape="S")),
] + [(f"spherical_{k}", (lambda k=k: spherical_tensegrity(k)))
     for k in ("tetrahedron", "hexahedron", "octahedron", "dodecahedron", "icosahedron")])
def test_shipped_files_match_the_generators(name, make):
    a, b = load_example(name), make()
    np.testing.assert_allclose(a.nodes, b.nodes, atol=1e-15)
    np.testing.assert_array_equal(a.members, b.members)
    np.testing.assert_allclose(a.rest_lengths, b.rest_lengths, rtol=1e-15)
    np.testing.assert_allclose(a.EA, b.EA)
    np.testing.assert_array_equal(a.pinned, b.pinned)
    assert a.member_kinds == b.member_kinds and [x.nodes for x in a.bodies] == [x.nodes for x in b.bodies]


@pytest.mark.parametrize("name", example_names())
def test_every_example_form_finds_to_a_stable_equilibrium(name):
    s = load_example(name)
    r = form_find(s)
    assert r.success and r.stable, r.message
    assert r.residual <= 1e-10 and r.residual_norm <= 1e-10 * s.EA.max()


# --------------------------------------------------------------------------- T-bar (5.2.1)
def _top_ratio(s):
    L = s.initial_lengths
    return lambda p: np.array([1, 1, 1, 1, p, p, 0.8, 0.8]) * L


def test_t_bar_with_a_roller_ends_at_a_limit_point_before_half():
    s = t_bar(0.8, supports="roller")
    path = rest_length_path(s, _top_ratio(s), np.linspace(0.8, 0.5, 13))
    assert not path.completed and path.limit_point is not None
    lo, hi = path.limit_point
    assert 0.55 < hi < lo < 0.575 and abs(lo - hi) < 1e-3
    assert "critical point between" in path.message
    t = path.member_forces
    assert t.shape == (len(path.parameters), 8)
    np.testing.assert_allclose(t[:, 4], t[:, 5], rtol=1e-9)       # mirror symmetry: top strings
    np.testing.assert_allclose(t[:, 6], t[:, 7], rtol=1e-9)       # and bottom strings equal
    assert np.all(t[:, :4] < 0) and np.all(t[:, 4:] > 0)          # bars pushed, strings pulled
    assert np.all(np.diff(t[:, 6]) > 0)                           # bottom strings load up
    eig = [r.min_eigenvalue for r in path.results]
    assert eig[-1] < 0.2 * eig[0]                                 # the stiffness is running out
    beyond = form_find(s.with_rest_lengths(_top_ratio(s)(0.55)), x0=path.results[-1].configuration)
    assert not beyond.success or np.abs(beyond.nodes - path.results[-1].nodes).max() > 0.05


def test_t_bar_forces_satisfy_equilibrium_with_the_single_self_stress():
    """Roller supports are statically determinate, so at every step the member forces are
    a multiple of the one self-stress mode of the equilibrium geometry."""
    s = t_bar(0.7, supports="roller")
    r = form_find(s)
    m = modes(s, r.configuration)
    assert m.self_stress.shape[1] == 1
    v = m.self_stress[:, 0]
    np.testing.assert_allclose(r.member_forces / np.linalg.norm(r.member_forces), v * np.sign(v @ r.member_forces),
                               atol=1e-9)


def test_t_bar_with_both_ends_pinned_loses_its_symmetric_branch():
    s = t_bar(0.8, supports="pinned")
    path = rest_length_path(s, _top_ratio(s), np.linspace(0.8, 0.5, 13))
    assert not path.completed and 0.55 < path.limit_point[0] < 0.575
    for r in path.results:                                        # symmetric shapes only
        np.testing.assert_allclose(r.nodes[[2, 3, 4], 0], 0.0, atol=1e-9)


# --------------------------------------------------------------------------- patio (5.2.2)
PAPER_H = np.array([[1.1045, -1.1635, -0.0216, 0.9906, -1.0094],
                    [0.6779, 0.6796, -1.1430, -0.6782, -0.6782],
                    [0, 0, 0, 0, 0]])                             # Eq. 87
PAPER_AR = np.array([[0, 0, -0.0189, -0.8251, 0.8300], [0, 0, -0.9998, 0.5649, 0.5577],
                     [0, 0, 0, 0, 0], [-0.8523, 0.8635, 0.0189, 0, 0], [-0.5231, -0.5044, 0.9998, 0, 0],
                     [0, 0, 0, 0, 0], [0, 0, 0, 0, 0], [0, 0, 0, 0, 0],
                     [-0.0259, 0.0060, 0.0199, 0, 0]])           # Eq. 88 (row 3 corrected)
PAPER_V2 = np.array([-0.4678, -0.4514, -0.4725, -0.4166, -0.4250])   # Eq. 89


def test_patio_shade_reproduces_eqs_87_to_89():
    s = load_example("patio_shade")
    r = form_find(s)
    assert r.success
    x = r.nodes
    H = (x[s.members[:, 1]] - x[s.members[:, 0]]).T
    np.testing.assert_allclose(H, PAPER_H, atol=1.5e-4)
    m = modes(s, r.configuration)
    assert m.rank == 4 and m.self_stress.shape == (5, 1) and m.mechanisms.shape == (9, 5)
    np.testing.assert_allclose(m.self_stress[:, 0], -PAPER_V2, atol=1.5e-4)
    from tensegrity_core.general import equilibrium_matrix

    np.testing.assert_allclose(equilibrium_matrix(s, r.configuration), PAPER_AR, atol=1.5e-4)


def test_patio_shade_mechanisms_and_stiffness():
    """Four mechanisms leave the plane (free node z, triangle z and its two tilts) and one
    stays in it; prestress stiffens all five: every eigenvalue of K_T is positive (Fig. 8)."""
    s = load_example("patio_shade")
    r = form_find(s)
    W = modes(s, r.configuration).mechanisms
    labels = s.layout.labels()
    for name in ("n6.z", "triangle.cz", "triangle.rx", "triangle.ry"):
        e = np.eye(9)[labels.index(name)]
        assert np.linalg.norm(W.T @ e) == pytest.approx(1.0, abs=1e-9)
    assert np.linalg.matrix_rank(W[[labels.index(n) for n in ("n6.x", "n6.y", "triangle.cx", "triangle.cy",
                                                               "triangle.rz")]], tol=1e-9) == 1
    ev = modal_analysis(s, r.configuration).eigenvalues
    assert ev.min() > 0 and r.rigid_body_modes == 0


def test_patio_shade_first_modes_against_fig_9():
    """Fig. 9 says the 1st and 4th modes of K_T leave the plane and the 2nd and 3rd are
    planar. The structure is planar and loaded in its plane, so K_T splits exactly into an
    in-plane block (n6.x, n6.y, cx, cy, rz) and an out-of-plane block (n6.z, cz, rx, ry):
    every mode lies in one of them. At the reconstructed equilibrium modes 1, 2 and 4 leave
    the plane and only mode 3 is planar. Which block comes first is no property of the
    structure: its coordinates mix metres and radians, so a change of length unit scales the
    two kinds of entries differently and reorders the modes. Expected eigenvalues [N/m,
    N m/rad]: an independent finite-difference Hessian of the strain energy (own code, the
    triangle turned by a rotation vector about its centroid, steps 1e-4)."""
    s = load_example("patio_shade")
    r = form_find(s)
    ma = modal_analysis(s, r.configuration)
    np.testing.assert_allclose(ma.eigenvalues[:4], [1.1126167e7, 1.2677081e7, 2.3597890e7, 2.8237802e7],
                               rtol=1e-6)
    labels = s.layout.labels()
    out_of_plane = [labels.index(n) for n in ("n6.z", "triangle.cz", "triangle.rx", "triangle.ry")]
    share = np.sum(ma.modes[out_of_plane, :4] ** 2, axis=0)
    np.testing.assert_allclose(share, [1, 1, 0, 1], atol=1e-9)


# --------------------------------------------------------------------------- table (5.2.3)
def test_table_self_stress_is_one_one_one_three_and_six_rigid_modes():
    s = load_example("tensegrity_table")
    r = form_find(s)
    assert r.success and r.rigid_body_modes == 6
    m = modes(s, r.configuration)
    np.testing.assert_allclose(m.self_stress[:, 0], np.array([1, 1, 1, 3]) / np.sqrt(12), atol=1e-12)
    np.testing.assert_allclose(r.member_forces / r.member_forces[0], [1, 1, 1, 3], rtol=1e-10)
    # symmetric shape: the top drops by d with 3 (0.7 H - d)/(0.3 H) = (0.7 s + d)/(0.3 s), H = 1, s = 0.5
    d = 1.4 / (3 / 1.0 + 1 / 0.5)
    np.testing.assert_allclose(r.member_lengths, [1 - d] * 3 + [0.5 + d], rtol=1e-10)


def test_table_mode_seven_is_a_relative_tilt_and_the_twist_is_mode_nine():
    """The paper says mode 7 (the most flexible) is the relative twist about Z. With
    l0 = 0.3 l and this geometry, modes 7-8 are a degenerate pair of relative tilts; the
    twist is mode 9 with eigenvalue 2 x 3 t R^2 / L (twist angle psi = rz_top - rz_bottom =
    sqrt(2) x mode amplitude). With a light prestress (l0 = 0.95 l) the twist is mode 7."""
    s = load_example("tensegrity_table")
    r = form_find(s)
    ma = modal_analysis(s, r.configuration)
    np.testing.assert_allclose(ma.eigenvalues[:6], 0.0, atol=1e-6 * ma.eigenvalues[-1])
    labels = s.layout.labels()
    rz = [labels.index("bottom.rz"), labels.index("top.rz")]
    twist = np.zeros(12)
    twist[rz] = [-1, 1]
    twist /= np.linalg.norm(twist)
    overlap = np.abs(ma.modes.T @ twist)
    assert np.argmax(overlap) == 8 and overlap[8] == pytest.approx(1.0, abs=1e-9)
    t, L = r.member_forces[0], r.member_lengths[0]
    assert ma.eigenvalues[8] == pytest.approx(2 * 3 * t * 1.0**2 / L, rel=1e-9)
    assert ma.eigenvalues[6] == pytest.approx(ma.eigenvalues[7], rel=1e-9)
    tilt = ma.modes[:, 6]
    assert np.linalg.norm(tilt[[labels.index(n) for n in ("bottom.rx", "bottom.ry", "top.rx", "top.ry")]]) > 0.99

    light = tensegrity_table(ratio=0.95)
    ml = modal_analysis(light, form_find(light).configuration)
    assert np.argmax(np.abs(ml.modes.T @ twist)) == 6


def test_a_narrow_table_is_unstable_and_tips_over():
    """Radius 0.5 m with l0 = 0.3 l: the symmetric state is a saddle (the prestress moment of
    the posts beats the strings' tilt stiffness); form-finding leaves it."""
    s = tensegrity_table(radius=0.5)
    r = form_find(s)
    assert r.success
    assert not np.allclose(r.member_forces / r.member_forces.max(), np.array([1, 1, 1, 3]) / 3, atol=1e-3)


# --------------------------------------------------------------------------- spherical (5.2.4)
@pytest.mark.parametrize("kind, faces, truncating, vertical", [
    ("tetrahedron", 4, 12, 6), ("hexahedron", 6, 24, 12), ("octahedron", 8, 24, 12),
    ("dodecahedron", 12, 60, 30), ("icosahedron", 20, 60, 30)])
def test_spherical_force_densities_rise_as_vertical_strings_shorten(kind, faces, truncating, vertical):
    ratios = [0.8, 0.6, 0.4, 0.2, 0.1]
    s = spherical_tensegrity(kind, vertical_ratio=ratios[0])
    is_t = np.array([n.startswith("t") for n in s.member_names])
    assert len(s.bodies) == faces and is_t.sum() == truncating and (~is_t).sum() == vertical
    x0, qt, qv = None, [], []
    for ratio in ratios:
        sr = spherical_tensegrity(kind, vertical_ratio=ratio)
        r = form_find(sr, x0=x0)
        assert r.success, (kind, ratio, r.message)
        q = r.member_forces / r.member_lengths
        np.testing.assert_allclose(q[is_t], q[is_t][0], rtol=1e-6)      # symmetry: one q_t
        np.testing.assert_allclose(q[~is_t], q[~is_t][0], rtol=1e-6)    # and one q_v
        qt.append(q[is_t][0])
        qv.append(q[~is_t][0])
        x0 = r.configuration
    assert np.all(np.diff(qt) > 0) and np.all(np.diff(qv) > 0)
    assert qt[0] > 0


def test_rigid_faces_are_stiffer_than_bar_faces():
    """The paper's RTS vs TTS comparison: with faces made of bars 1000 x stiffer than the
    strings, the bar version is softer (smallest K_T eigenvalue) at the same rest lengths."""
    rts = form_find(spherical_tensegrity("tetrahedron", vertical_ratio=0.5))
    tts = form_find(spherical_tensegrity("tetrahedron", vertical_ratio=0.5, rigid=False))
    assert rts.success and tts.success
    assert rts.min_eigenvalue > tts.min_eigenvalue
    v = np.array([n.startswith("v") for n in rts.structure.member_names])
    vt = np.array([n.startswith("v") for n in tts.structure.member_names])
    assert rts.member_forces[v].mean() == pytest.approx(tts.member_forces[vt].mean(), rel=0.05)


@pytest.mark.parametrize("ratio", [0.8, 0.1])
def test_rigid_and_bar_faces_carry_the_same_vertical_forces(ratio):
    """Sect. 5.2.4 says the vertical strings' force "in RTS increases a lot more than that of
    TTS" as their rest length falls from 0.8 l to 0.1 l. The bar version differs from the
    rigid one only by its face bars' elongation t_b l_b / EA_b (EA_b = 1000 EA_s). A
    vertical string joins two faces, so its length moves by at most about two bar
    elongations, and its force t_v = EA_s (l_v - l0_v) / l0_v by the fraction
    dt_v / t_v <= 2 max(t_b l_b / EA_b) / (l_v - l0_v): ~2e-3 at 0.8 l, ~2e-2 at 0.1 l.
    The forces agree to that, not 'a lot more'."""
    rts = form_find(spherical_tensegrity("tetrahedron", vertical_ratio=ratio))
    tts = form_find(spherical_tensegrity("tetrahedron", vertical_ratio=ratio, rigid=False))
    assert rts.success and tts.success
    s = tts.structure
    v = np.array([n.startswith("v") for n in s.member_names])
    bar = np.array([k == "bar" for k in s.member_kinds])
    assert bar.sum() == 12                                              # 4 triangles of bars
    elongation = np.abs(tts.member_forces[bar]) * tts.member_lengths[bar] / s.EA[bar]
    bound = 2 * elongation.max() / np.mean(tts.member_lengths[v] - s.rest_lengths[v])
    rv = np.array([n.startswith("v") for n in rts.structure.member_names])
    assert abs(rts.member_forces[rv].mean() / tts.member_forces[v].mean() - 1) <= bound
    assert bound < 0.02


# --------------------------------------------------------------------------- spine (5.2.5)
def test_spine_bends_into_c_and_s_shapes():
    c = form_find(load_example("spine_c"))
    centres = c.nodes[0::5]
    assert c.success and np.all(np.diff(centres[:, 0]) > 0)          # bends steadily toward +x (shorter side)
    assert np.abs(centres[:, 1]).max() < 1e-8                         # in the x-z plane
    curvature = np.diff(centres[:, 0], 2)
    assert np.all(curvature > 0)                                      # one sense of curvature: a C
    s = form_find(load_example("spine_s"))
    k = np.diff(s.nodes[0::5, 0], 2)
    assert s.success and k[0] * k[-1] < 0                             # curvature changes sign: an S
    assert np.all(s.member_forces > 0)                                # every string stays taut
