"""IK solutions on singular sets: the IK and the controller's planner say the same thing.

The paper (Sect. 5.3) calls the folded pose q_F = [0, 0, pi/2] "a singular configuration":
it is an equilibrium (the mechanism settles there) and the only one putting D at (0, L).
The IK returns it as valid and names the set; the planner refuses it as a target naming the
same set and the same distance. The set names and distances here are recomputed from the
geometry (the lines rho1 + rho2 = 2L, rho1 = L, (2 k3 + k2) rho2 = k2 rho1 and the point
rho = 0), not read from the code's formulas.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings

from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics, inverse_kinematics
from tensegrity_core.class2.control.errors import SINGULAR_PATH, PlanningError
from tensegrity_core.class2.control.planner import plan_move
from tests.class2.strategies import configurations, parameter_sets, scaled


def _distances(rho1, rho2, p):
    """Distance [L] in the actuator plane from (rho1, rho2) to each singular set, by
    projecting onto each line (point-to-line distance |n . r - c| / |n|)."""
    K = 2 * p.k3 + p.k2
    return {"lambda1": abs(rho1 + rho2 - 2 * p.L) / math.sqrt(2) / p.L,
            "lambda2": abs(rho1 - p.L) / p.L,
            "beta_half_pi": abs(K * rho2 - p.k2 * rho1) / math.sqrt(K * K + p.k2 * p.k2) / p.L,
            "folded": math.hypot(rho1, rho2) / p.L}


@settings(max_examples=40)
@given(rho=configurations(), params=parameter_sets())
def test_each_solution_names_its_nearest_singular_set(rho, params):
    rho1, rho2 = scaled(rho, params)
    fk = forward_kinematics(rho1, rho2, params)
    res = inverse_kinematics(fk.x, fk.y, params, paper_range=False)
    for c in res.valid:
        dist = _distances(c.rho1, c.rho2, params)
        assert c.singularity_distance == pytest.approx(min(dist.values()), abs=1e-12)
        assert dist[c.singular_set] == pytest.approx(c.singularity_distance, abs=1e-12)
    named = "lies on the singular set" in res.message
    if any(c.singularity_distance <= 1e-9 for c in res.valid):
        assert named, res.message
    if all(c.singularity_distance >= 1e-5 for c in res.valid):
        assert not named, res.message


@pytest.mark.parametrize("target, rho, name", [
    ((0.0, 1.0), (0.0, 0.0), "folded"),            # the paper's q_F: D at (0, L)
    ((0.9, 1.0), (0.9, 0.3), "beta_half_pi"),      # on the fold y = L: D above B, rho2 = rho1 / 3
    ((2.0, 0.0), (1.0, 1.0), "lambda1"),           # struts flat: D on the X axis at 2L
    ((1.0 + math.cos(math.atan2(math.sqrt(4 - 1.7**2), 1.1)), math.sin(math.atan2(math.sqrt(4 - 1.7**2), 1.1))),
     (1.0, 0.7), "lambda2"),                       # F at A: beta = atan2(k2 lambda1, K rho2 - k2 rho1)
])
def test_a_valid_solution_on_a_singular_set_is_named_and_the_planner_refuses_it(target, rho, name):
    """~2 ms: the planner refuses at the target check, before planning a path."""
    res = inverse_kinematics(*target, PAPER_PARAMS)
    assert res.success and len(res.valid) == 1
    sol = res.valid[0]
    assert (sol.rho1, sol.rho2) == pytest.approx(rho, abs=1e-9)
    assert sol.singular_set == name and sol.singularity_distance == pytest.approx(0.0, abs=1e-9)
    assert f"lies on the singular set {name}" in res.message
    assert ("dD/drho" in res.message) == (name != "lambda2")     # regular there: see the test below
    with pytest.raises(PlanningError, match=f"singular set {name}") as err:
        plan_move((0.7, 0.7, forward_kinematics(0.7, 0.7).beta), target, PAPER_PARAMS, duration=2.0)
    assert err.value.code == SINGULAR_PATH


def test_a_regular_target_names_no_singular_set():
    fk = forward_kinematics(0.7, 0.7)
    res = inverse_kinematics(fk.x, fk.y)
    assert res.message == "1 valid solution of 2 candidates"
    assert res.valid[0].singular_set == "lambda2" and res.valid[0].singularity_distance == pytest.approx(0.3)


def _D(rho1, rho2):
    """End-effector of the equilibrium (paper parameters): dU/dbeta = 0 of the two springs
    CD (k3) and DE (k2) that move with beta gives beta = atan2(k2 lambda1, K rho2 - k2 rho1)."""
    lam1 = math.sqrt(max(0.0, 4 - (rho1 + rho2) ** 2))
    beta = math.atan2(lam1, 3 * rho2 - rho1)
    return np.array([rho1 + math.cos(beta), math.sin(beta)])


@pytest.mark.parametrize("rho, name", [((0.5, 1.5 - 1e-9), "lambda1"), ((1.0 - 1e-9, 0.7), "lambda2"),
                                       ((0.6, 0.2), "beta_half_pi"), ((1e-9, 1e-9), "folded")])
def test_what_the_message_says_is_singular_holds(rho, name):
    """A one-sided difference of D(rho) near each set: the Jacobian is singular (a small
    determinant or an unbounded entry) on lambda1, beta_half_pi and folded, regular on
    lambda2 (where the dynamics, not the kinematics, break down); the message says which."""
    from tensegrity_core.class2.singularities.distances import SINGULAR_MEANINGS

    h = 1e-7
    J = np.column_stack([(_D(rho[0] - h * (i == 0), rho[1] - h * (i == 1)) - _D(*rho)) / -h for i in (0, 1)])
    singular = abs(np.linalg.det(J)) < 1e-3 or np.abs(J).max() > 1e3
    says = "dD/drho" in SINGULAR_MEANINGS[name]
    assert singular == says == (name != "lambda2"), (name, J)
