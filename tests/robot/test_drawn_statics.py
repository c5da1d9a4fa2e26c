"""The robot statics over drawn robots (``test_drawn_robots.robots``: masses and cable
stiffnesses drawn over the whole accepted range, 1e-15 to 1e15 of their unit): every entry
point (:meth:`Robot.structure`, which a robot scene names its parts by; :func:`rest_shape`;
:func:`tipping_step`, which the rolling gait and the closed-loop roll run) gives an answer
or refuses in one line that names no member the user did not write (the rods' stand-in
bars are the statics' own)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.errors import ConvergenceError
from tensegrity_core.robot import cable
from tensegrity_core.robot.robot_schema import robot_from_dict
from tensegrity_core.robot.statics import rest_shape
from tensegrity_core.robot.tipping import tipping_step
from tests.robot.test_drawn_robots import robots

# among the suite's longest files: ./run test starts them first (tests/conftest.py)
pytestmark = pytest.mark.slow


def _one_line_about_the_users_parts(err: Exception, rods: tuple[str, ...]) -> None:
    text = str(err)
    assert text and "\n" not in text
    assert not any(f"'{name}'" in text for name in rods), text


@settings(max_examples=40, deadline=None)
@given(robot=robots(floor=False, pins="none"), tip=st.booleans())
def test_every_statics_entry_point_answers_or_refuses_in_one_line(robot, tip):
    """A robot's rods on three of their caps tip or refuse in one line. A found rest shape is an equilibrium of the robot's own cables in newtons: each cable's
    force is ``k (l - l0)`` where taut (:func:`cable.tension`), to the form-finding's relative
    tolerance of the forces that meet at its nodes, whatever the force unit of the structure."""
    r = robot_from_dict(robot)
    s = r.structure()
    assert s.member_names == r.member_names
    X = r.nodes
    try:
        shape = rest_shape(r)
    except ConvergenceError as err:
        _one_line_about_the_users_parts(err, r.rods.names)
    else:
        X, e = shape.nodes, r.cables.ends
        l = np.linalg.norm(X[e[:, 1]] - X[e[:, 0]], axis=1)
        T = cable.tension(l, 0.0, r.cables.rest_length, r.cables.stiffness, 0.0)
        scale = np.abs(shape.member_forces).max()
        np.testing.assert_allclose(shape.member_forces[r.cable_members()], T, rtol=1e-6, atol=1e-6 * scale)
    if tip and len(r.rods) >= 2:                  # on three caps of the rest shape, or else the drawing
        a, b, c = (int(i) for i in r.rods.ends.reshape(-1)[:3])
        try:
            tipping_step(r, X, (a, b, c), r.cables.rest_length.copy())
        except ConvergenceError as err:
            _one_line_about_the_users_parts(err, r.rods.names)
