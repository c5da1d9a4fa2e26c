"""The class-2 parameters' accepted range (``Class2Params``, ``MAGNITUDE_RANGE``): every value
inside it gives results that are homogeneous in the strut length and in the stiffnesses, and
every value outside it is refused by name, with its unit and the range.

Expected values come from dimensional analysis and from the energy of Eq. (10) derived here:
with D = B + L (cos beta, sin beta), C - B = (rho2, 0) and E - B = ((rho2 - rho1)/2, lambda1/2)
(lambda1 = sqrt(4 L^2 - (rho1 + rho2)^2)), the beta-dependent energy of CD (k3) and DE (k2) is
stationary where tan beta = k2 lambda1 / ((2 k3 + k2) rho2 - k2 rho1). beta depends on
rho/L and on stiffness ratios only; K scales with the stiffnesses. Outside 1e-15..1e15 these
failed: ``L = 1e-300 m`` gave beta = 0 (D on the X axis) and ``k = 1e-300 N/m`` a
ZeroDivisionError in the IK (issue 12's "every extreme value works or is refused by name").
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics, inverse_kinematics, stiffness_along_coordinates
from tensegrity_core.class2.params import MAGNITUDE_RANGE, Class2Params
from tensegrity_core.errors import ParameterError

LO, HI = MAGNITUDE_RANGE
#: log10 of a scale anywhere in the accepted range, ends included.
EXPONENTS = st.one_of(st.sampled_from([math.log10(LO), math.log10(HI)]), st.floats(math.log10(LO), math.log10(HI)))
#: log10 of the springs' scale k (1e-14..1e12): springs of 0.2 k .. 5 k and struts of 1000 k stay in the range.
K_EXPONENTS = EXPONENTS.map(lambda e: min(max(e, math.log10(LO) + 1.0), math.log10(HI) - 3.0))


def _beta(rho1: float, rho2: float, k2: float, k3: float) -> float:
    """The energy minimum of Eq. (10) at L = 1 (module docstring)."""
    lam1 = math.sqrt(4.0 - (rho1 + rho2) ** 2)
    return math.atan2(k2 * lam1, (2.0 * k3 + k2) * rho2 - k2 * rho1)


@settings(max_examples=100)
@given(EXPONENTS, K_EXPONENTS, st.floats(0.05, 0.95), st.floats(0.05, 0.95), st.floats(0.2, 5.0), st.floats(0.2, 5.0))
def test_kinematics_are_homogeneous_over_the_whole_accepted_range(e_len, e_k, r1, r2, a, b):
    L, k = 10.0**e_len, 10.0**e_k
    params = Class2Params(L=L, k1=k, k2=a * k, k3=b * k, k4=k, ka=10.0 * k, kb=1000.0 * k)
    rho1, rho2 = r1, r2 * min(1.0, 2.0 - r1)
    beta = _beta(rho1, rho2, a, b)
    fk = forward_kinematics(rho1 * L, rho2 * L, params)
    assert fk.beta == pytest.approx(beta, abs=1e-9)
    x, y = rho1 + math.cos(beta), math.sin(beta)
    ik = inverse_kinematics(x * L, y * L, params, paper_range=False)
    assert any(math.hypot(c.rho1 / L - rho1, c.rho2 / L - rho2) < 1e-6 for c in ik.valid), ik


@settings(max_examples=40)
@given(EXPONENTS, K_EXPONENTS, st.floats(0.1, 0.9), st.floats(0.1, 0.9), st.floats(-2.0, 2.0))
def test_stiffness_scales_with_the_springs_over_the_whole_accepted_range(e_len, e_k, r1, r2, load):
    L, k = 10.0**e_len, 10.0**e_k
    params = Class2Params(L=L, k1=k, k2=k, k3=k, k4=k, ka=10.0 * k, kb=1000.0 * k)
    got = np.asarray(stiffness_along_coordinates(r1 * L, r2 * L, load * k * L, params).K) / k
    unit = np.asarray(stiffness_along_coordinates(r1, r2, load, PAPER_PARAMS).K)
    np.testing.assert_allclose(got, unit, rtol=1e-7, atol=1e-9 * np.abs(unit).max())
    np.testing.assert_allclose(got, got.T, rtol=0, atol=1e-12 * np.abs(got).max())


@pytest.mark.parametrize(("name", "value", "words"), [
    ("L", 1e-300, "parameter L must be between 1e-15 m and 1e+15 m, got 1e-300"),
    ("L", 1e16, "parameter L must be between 1e-15 m and 1e+15 m, got 1e+16"),
    ("k2", 1e-300, "parameter k2 must be between 1e-15 N/m and 1e+15 N/m"),
    ("kb", 1e300, "parameter kb must be between 1e-15 N/m and 1e+15 N/m"),
    ("m", 5e-324, "parameter m must be between 1e-15 kg and 1e+15 kg"),
    ("c3", 1e16, "parameter c3 must be at most 1e+15 N s/m"),
])
def test_a_parameter_outside_the_range_is_refused_by_name_with_its_unit(name, value, words):
    with pytest.raises(ParameterError, match=words.replace("+", r"\+")):
        PAPER_PARAMS.with_overrides({name: value})
