"""The tangent stiffness against a central difference of the generalized force, shared by
the property tests of the general statics (tests/hard)."""

from __future__ import annotations

import numpy as np

from tensegrity_core.general import generalized_force
from tensegrity_core.general.statics import member_lengths


def slack_switch(s, config, d, h: float) -> bool:
    """Whether a string changes between slack and taut within +-h along d (a kink of V)."""
    signs = [np.sign(member_lengths(s, config.retract(e * d).coords) - s.rest_lengths) for e in (-h, 0.0, h)]
    return bool(np.any(s.is_string & ((signs[0] != signs[1]) | (signs[1] != signs[2]))))


def stiffness_along(s, config, K, d, h: float):
    """``(fd, expected, P)``: the central difference ``-(P(U + h d) - P(U - h d)) / 2h`` and
    what K_T predicts for it, ``K_T d`` with the body rotation rows corrected by
    ``1/2 hat(M)`` (docs/general.md: -dM/dtheta = K_T + 1/2 hat(M), the skew part a
    symmetric Hessian cannot carry); ``P`` the generalized force at ``config``."""
    fd = -(generalized_force(s, config.retract(h * d)) - generalized_force(s, config.retract(-h * d))) / (2 * h)
    P = generalized_force(s, config)
    expected = K @ d
    for slot in s.layout.body_dof:
        rot = slot + 3 + np.arange(3)
        expected[rot] += 0.5 * np.cross(P[rot], d[rot])
    return fd, expected, P
