"""The runtime dynamics equals the first-principles sympy derivation.

derive_dynamics derives T, M, the Christoffel terms, H and grad U from the strut
kinematics and the spring table; these tests run its self-checks and compare the
runtime module with the lambdified derivation at random states.
"""

from __future__ import annotations

import numpy as np

from tensegrity_core.class2 import geometry
from tensegrity_core.class2.params import Class2Params


def test_derivation_self_checks_all_pass():
    from studies.derivation import derive_dynamics as dd

    checks = dd.check_derivation(seed=3)
    failed = [name for name, ok in checks.items() if not ok]
    assert not failed, f"failed: {failed}"
    # Every strut, the Euler-Lagrange cross-check and every closed form were examined.
    assert {"rigid:AE", "rigid:BF", "rigid:BD", "rigid:CE", "euler_lagrange", "H_is_sum_c_grad_grad"} <= set(checks)
    assert sum(name.startswith("closed:") for name in checks) == 17


def test_identity_check_rejects_a_wrong_closed_form():
    """The 40-digit comparison used by check_derivation is not vacuous."""
    import random

    import sympy as sp

    from studies.derivation import derive_dynamics as dd

    sd = dd.derive()
    wrong = dd.closed_forms(sd)["C1"] * (1 + sp.Rational(1, 10**12))
    assert not dd._equal(wrong, dd.derived_counterparts(sd)["C1"], random.Random(0))


def test_symbolic_nodes_match_geometry_module():
    from studies.derivation import derive_dynamics as dd

    sd = dd.derive()
    rng = np.random.default_rng(5)
    for _ in range(10):
        L = rng.uniform(0.5, 2.0)
        q = np.array([rng.uniform(0, L), rng.uniform(0, L), rng.uniform(-3, 3)])
        subs = {sd.p["L"]: L, **dict(zip(sd.q, q))}
        sym = np.array([[float(c.subs(subs)) for c in sd.nodes[n]] for n in geometry.NODE_NAMES])
        np.testing.assert_allclose(sym, geometry.node_positions(q, Class2Params(L=L)), atol=1e-14)


def test_runtime_matches_derivation_at_random_states():
    from studies.derivation import derive_dynamics as dd

    errors = dd.check_runtime(n_points=30, seed=11)
    assert set(errors) >= {"kinetic_energy", "mass_matrix", "velocity_terms", "damping_matrix", "potential_energy",
                           "potential_gradient", "potential_hessian", "generalized_forces", "acceleration",
                           "Class2Dynamics.acceleration_scalar"}
    worst = max(errors, key=errors.get)
    assert errors[worst] < 1e-11, f"{worst}: {errors[worst]:.3g}"
