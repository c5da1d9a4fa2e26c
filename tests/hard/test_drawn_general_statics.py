"""The general statics over drawn structures at the edges of the accepted ranges
(:func:`tests.hard.strategies.drawn_structures`: coplanar, collinear, clustered and coincident
nodes, duplicate members, mechanisms with many modes, EA over 21 decades, lengths from 1 mm
to 1 km, prestress of either sign, masses, gravity, loads, a rigid body).

Every public entry point (the structure itself, ``equilibrium_matrix``, ``modes``,
``tangent_stiffness``, ``form_find`` with dense and sparse Newton and dynamic relaxation,
the ``tensegrity formfind`` and ``tensegrity modes`` commands) either answers or refuses with
a :class:`~tensegrity_core.errors.TensegrityError` of one line, and no numpy warning. An answer is checked against
what is derived here:

- ``A t = G^T A_2 t``: the node forces of member forces ``t`` summed from the geometry in
  this file (``A_2``), carried to the coordinates by the motion of each node per coordinate
  (``G``, the kinematics of ``transformation_matrix``, checked against finite differences in
  test_kinematics.py). Tolerance: a sum of ``k`` products is exact to ``gamma_k`` times the
  sum of their magnitudes (``gamma_k ~ k eps``; Higham, Sect. 3.1), the unit vectors to a few
  eps more.
- The modes: orthonormal; ``A S`` and ``A^T M`` below the documented singular-value
  threshold; the self-stress and mechanism spaces equal the null spaces of an SVD done here
  (LAPACK's ``gesvd``, not numpy's ``gesdd``), to Wedin's bound ``eps s_1 / gap``.
- ``K_T`` symmetric and equal to the central difference of the generalised force (the
  rotations of a body corrected by ``1/2 hat(M)``, docs/general.md), with ``h`` chosen
  between rounding (``eps |x| / h``) and truncation (``h^2 / l_min^2``).
- A form-found structure: its members obey ``t = EA (l - l0) / l0`` (slack strings 0) at its
  nodes, recomputed here, and it is balanced (without bodies: the residual recomputed from
  the plain equations) to the tolerance or its rounding level.

CPU: about 20 s in the ``ci`` profile (derandomised; measured under load 28).
"""

from __future__ import annotations

import contextlib
import io
from functools import partial

import numpy as np
import pytest
import scipy.linalg as la
from hypothesis import HealthCheck, assume, event, given, settings

from tensegrity_core.errors import TensegrityError
from tensegrity_core.general import (
    Configuration,
    Structure,
    equilibrium_matrix,
    form_find,
    modes,
    save_structure,
    tangent_stiffness,
    transformation_matrix,
)
from tensegrity_ros.cli import main
from tests.general.independent import member_forces as plain_member_forces
from tests.general.independent import relative_residual
from tests.hard.stiffness_check import slack_switch, stiffness_along
from tests.hard.strategies import drawn_structures

EPS = float(np.finfo(float).eps)
#: A numpy warning (overflow, 0/0) printed to the user is a defect too.
# among the suite's longest files: ./run test starts them first (tests/conftest.py)
pytestmark = [pytest.mark.filterwarnings("error::RuntimeWarning"), pytest.mark.slow]


def answer_or_refusal(call):
    """``call()``'s answer, or None when it refused with one line (any other exception, or a
    refusal of several lines, fails the test)."""
    try:
        return call()
    except TensegrityError as err:
        text = str(err)
        assert text and "\n" not in text and len(text) < 600, text
        return None


def built(kwargs: dict) -> Structure | None:
    """The structure, or None when it refused its arguments (``--hypothesis-show-statistics``
    counts the kinds of draw and the outcomes)."""
    s = answer_or_refusal(lambda: Structure.from_arrays(**kwargs))
    event(kwargs["name"].split(" (seed")[0] + (": refused" if s is None else ""))
    return s


def node_forces(s: Structure, x: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``-A_2 t`` (n, 3): the force member forces ``t`` (tension +) exert on each node, from the
    geometry; and per node the sum of the magnitudes that went into it (for the bound)."""
    h = x[s.members[:, 1]] - x[s.members[:, 0]]
    u = h / np.linalg.norm(h, axis=1)[:, None]
    f = np.zeros((s.n_nodes, 3))
    size = np.zeros((s.n_nodes, 3))
    np.add.at(f, s.members[:, 0], t[:, None] * u)
    np.add.at(f, s.members[:, 1], -t[:, None] * u)
    np.add.at(size, s.members[:, 0], np.abs(t[:, None] * u))
    np.add.at(size, s.members[:, 1], np.abs(t[:, None] * u))
    return f, size


@settings(max_examples=80, suppress_health_check=[HealthCheck.filter_too_much])
@given(drawn_structures())
def test_equilibrium_matrix_and_modes_answer_and_hold(kwargs):
    s = built(kwargs)
    if s is None:
        return
    A = answer_or_refusal(lambda: equilibrium_matrix(s, None))
    m = answer_or_refusal(lambda: modes(s))
    assert (A is None) == (m is None)
    if A is None:
        return
    n_dof, n_members = A.shape
    assert n_dof == s.layout.n_dof and n_members == s.n_members

    # A t = G^T A_2 t, A_2 t summed from the geometry here
    t = np.random.default_rng(0).normal(size=n_members) * s.EA
    config = Configuration.initial(s)
    G = transformation_matrix(config).toarray()           # (3n, n_dof): node motion per coordinate
    f, size = node_forces(s, s.nodes, t)
    expected = -G.T @ f.ravel()
    k = 12 + 2 * int(np.bincount(s.members.ravel()).max())
    bound = (8 + 2 * k) * EPS * (np.abs(G).T @ size.ravel())
    assert np.all(np.abs(A @ t - expected) <= bound + 1e-300)

    # modes: the documented threshold, an SVD of our own, orthonormality, null spaces
    S, M = m.self_stress, m.mechanisms
    s_own = la.svd(A, compute_uv=False, lapack_driver="gesvd") if min(A.shape) else np.zeros(0)
    top = s_own[0] if s_own.size else 0.0
    threshold = 1e-8 * top
    assume(not np.any(np.abs(s_own - threshold) <= 1e-3 * threshold))   # no value at the threshold itself
    rank = int(np.sum(s_own > threshold))
    assert m.rank == rank
    assert S.shape == (n_members, n_members - rank) and M.shape == (n_dof, n_dof - rank)
    for Q in (S, M):
        np.testing.assert_allclose(Q.T @ Q, np.eye(Q.shape[1]), atol=8 * max(A.shape) * EPS)
    floor = threshold + 8 * max(A.shape) * EPS * top
    assert np.linalg.norm(A @ S, 2) <= floor if S.size else True
    assert np.linalg.norm(A.T @ M, 2) <= floor if M.size else True
    U, sv, Vt = la.svd(A, lapack_driver="gesvd")
    gap = (sv[rank - 1] if rank else np.inf) - (sv[rank] if rank < len(sv) else 0.0)
    for Q, basis in ((S, Vt[rank:].T), (M, U[:, rank:])):
        if Q.shape[1] and gap > 1e-6 * top:
            wedin = 16 * max(A.shape) * EPS * top / gap + threshold / gap
            assert np.abs(Q @ Q.T - basis @ basis.T).max() <= wedin


@settings(max_examples=60, suppress_health_check=[HealthCheck.filter_too_much])
@given(drawn_structures())
def test_tangent_stiffness_answers_symmetric_and_the_jacobian_of_the_force(kwargs):
    s = built(kwargs)
    if s is None:
        return
    config = Configuration.initial(s)
    K = answer_or_refusal(lambda: tangent_stiffness(s, config))
    if K is None or K.size == 0:                          # refused, or nothing free to move
        return
    assert np.all(np.isfinite(K))
    scale = np.abs(K).max()
    assert np.abs(K - K.T).max() <= 8 * EPS * scale
    d = np.random.default_rng(1).normal(size=s.layout.n_dof)
    d /= np.linalg.norm(d)
    lengths = np.linalg.norm(s.nodes[s.members[:, 1]] - s.nodes[s.members[:, 0]], axis=1)
    l_min, x_max = lengths.min(), max(np.abs(s.nodes).max(), lengths.max())
    radius = max([np.linalg.norm(s.nodes[list(b.nodes)] - s.nodes[list(b.nodes)].mean(axis=0), axis=1).max()
                  for b in s.bodies] + [0.0])
    reach = 1.0 + radius                                  # node motion per unit of d (a rotation moves by radius)
    h = (EPS * x_max * l_min**2) ** (1 / 3) / reach       # rounding eps x/h against truncation h^2/l^2
    assume(not slack_switch(s, config, d, h))
    fd, expected, P = stiffness_along(s, config, K, d, h)
    forces = np.abs(plain_member_forces(s, s.nodes)).max() + np.abs(P).max()
    rounding = 64 * EPS * (scale * x_max + forces) / h
    truncation = 8 * (h * reach / l_min) ** 2 * (scale + forces / l_min)
    assert np.abs(fd - expected).max() <= rounding + truncation


METHODS = (("newton", {"linear_solver": "dense"}), ("newton", {"linear_solver": "sparse"}),
           ("dynamic_relaxation", {"max_iter": 1500}))


@settings(max_examples=30, suppress_health_check=[HealthCheck.filter_too_much])
@given(drawn_structures())
def test_form_finding_answers_and_its_members_obey_their_law(kwargs):
    s = built(kwargs)
    if s is None:
        return
    for method, options in METHODS:
        r = answer_or_refusal(partial(form_find, s, method=method, **options))
        event(f"{method} {options}: " + ("refused" if r is None else "converged" if r.success else r.status.name))
        if r is None:
            continue
        assert r.message and "\n" not in r.message
        if not r.success:
            continue
        x = r.nodes
        assert np.all(np.isfinite(x))
        lengths = np.linalg.norm(x[s.members[:, 1]] - x[s.members[:, 0]], axis=1)
        np.testing.assert_allclose(r.member_lengths, lengths, rtol=4 * EPS, atol=0)
        t = plain_member_forces(s, x)
        # t = EA (l - l0)/l0: l known to a few eps of the coordinates it comes from
        known = 8 * EPS * s.EA / s.rest_lengths * (np.abs(x[s.members]).max(axis=(1, 2)) + lengths)
        assert np.all(np.abs(r.member_forces - t) <= known + 4 * EPS * np.abs(t))
        assert np.all(r.member_forces[s.is_string] >= 0)
        if not s.bodies:
            # balanced to tol or to the rounding level of the forces at a node (convergence.py)
            floor = np.zeros(s.n_nodes)
            np.add.at(floor, s.members.ravel(), np.repeat(known, 2))
            scale = np.linalg.norm(s.loads, axis=1) + np.bincount(s.members.ravel(), np.repeat(np.abs(t), 2),
                                                                   s.n_nodes)
            free = ~s.pinned.all(axis=1)
            allowed = 1e-10 + 8 * np.divide(floor, scale, out=np.zeros(s.n_nodes), where=scale > 0)[free]
            assert np.all(relative_residual(s, x) <= allowed)


@contextlib.contextmanager
def form_finding_once():
    """``form_find`` answering a second call with the same structure and the same effective
    arguments by the first call's result: ``formfind --quiet`` and ``modes --at-equilibrium``
    both form-find the drawn file with Newton's defaults, and form-finding is deterministic
    (the same floating-point operations on the same input), so the second command gets the
    very result it would compute (half the test's cost; a refusal is not kept, it is raised
    again by the call itself)."""
    import tensegrity_core.general as general

    real, kept = general.form_find, {}

    def once(structure: Structure, **kwargs):
        given = {k: v for k, v in kwargs.items() if v is not None}
        given.setdefault("method", "newton")
        if given["method"] == "newton":
            given.setdefault("linear_solver", "auto")
        key = (structure.name, structure.nodes.tobytes(), structure.rest_lengths.tobytes(),
               structure.EA.tobytes(), tuple(sorted(given.items())))
        if key not in kept:
            kept[key] = real(structure, **kwargs)
        return kept[key]

    general.form_find = once
    try:
        yield
    finally:
        general.form_find = real


def run_cli(args: list[str]) -> tuple[int, str]:
    """``tensegrity ARGS`` in this process: its exit code and what it wrote on stderr."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(args)
    return code, err.getvalue()


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                   HealthCheck.filter_too_much])
@given(drawn_structures())
def test_the_commands_answer_or_refuse_in_one_line(tmp_path, kwargs):
    s = built(kwargs)
    if s is None:
        return
    path = tmp_path / "drawn.yaml"
    save_structure(s, path)
    with form_finding_once():
        for args in (["formfind", str(path), "--quiet"], ["modes", str(path), "--stiffness", "3"],
                     ["modes", str(path), "--at-equilibrium"]):
            code, err = run_cli(args)
            assert code in (0, 1, 2), (args, code, err)
            lines = err.splitlines()
            if code:
                assert len(lines) == 1 and lines[0].startswith("error: ") and len(lines[0]) < 600, (args, err)


def test_the_strategy_reaches_every_geometry():
    """The strategy draws each geometry, and a coincident pair is refused by the structure
    naming the member (so the degenerate draws are not all filtered away)."""
    from tests.hard.strategies import GEOMETRIES

    seen = set()

    @settings(max_examples=200, database=None)
    @given(drawn_structures())
    def collect(kwargs):
        seen.add(kwargs["name"].split(" structure")[0].removeprefix("drawn "))
        if kwargs["name"].startswith("drawn coincident"):
            with pytest.raises(TensegrityError, match="zero length"):
                Structure.from_arrays(**kwargs)

    collect()
    assert seen == set(GEOMETRIES)
