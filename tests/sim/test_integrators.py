"""The compiled integrators (tensegrity_core.sim.integrators) on general structures.

Oracles: the closed-form oscillation of a mass between two bars (RK4's error falls 16-fold
per halved step: fourth order), scipy's DOP853 (the same method, its stages in Python) and
RK4 with its stages through the numpy kernels (the same arithmetic, not compiled).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from tensegrity_core.sim import SceneError, simulate
from tensegrity_core.sim.general.kernels.jit import KERNELS_VARIABLE, have_numba

from .test_general import BODIES, LINE, general_scene

pytestmark = pytest.mark.skipif(not have_numba(), reason="the compiled integrators need numba (the 'fast' extra)")

X0 = 0.05
OMEGA = np.sqrt(2 * 100.0 / 1.0 / 2.0)       # two bars of EA/l0 = 100 N/m on 2 kg


def _line(method, **integrator):
    structure = dict(LINE, nodes={"a": [-1.0, 0, 0], "m": [X0, 0, 0], "b": [1.0, 0, 0]})
    return general_scene(structure, ["inertia", "springs"], duration=2.0,
                         integrator={"method": method, "rtol": 1e-10, "atol": 1e-12, **integrator})


def _with_kernels(kernels, fn):
    old = os.environ.get(KERNELS_VARIABLE)
    os.environ[KERNELS_VARIABLE] = kernels
    try:
        return fn()
    finally:
        if old is None:
            os.environ.pop(KERNELS_VARIABLE)
        else:
            os.environ[KERNELS_VARIABLE] = old


def test_rk4_is_fourth_order_against_the_closed_form():
    errors = []
    for step in (0.02, 0.01, 0.005):
        traj = simulate(_line("RK4", max_step=step))
        assert traj.stats["steps"] == round(2.0 / step)
        errors.append(np.abs(traj.nodes[:, 1, 0] - X0 * np.cos(OMEGA * traj.times)).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 13) & (ratios < 19)), (errors, ratios)      # 2^4 = 16


def test_rk4_compiled_and_through_the_numpy_kernels_agree_to_rounding():
    scene = general_scene(BODIES, ["inertia", "springs", {"damping": {"c": 0.3}}], duration=0.3,
                          integrator={"method": "RK4", "max_step": 1e-3})
    fast = simulate(scene)
    plain = _with_kernels("numpy", lambda: simulate(scene))
    # steps of 1 ms, a string's slack/taut event cutting one of them in two (the grid restarts
    # there, its last step shortened to land on the end)
    assert [e[1:] for e in fast.events] == [e[1:] for e in plain.events]
    np.testing.assert_allclose([e[0] for e in fast.events], [e[0] for e in plain.events], rtol=0, atol=1e-12)
    assert fast.stats["steps"] == plain.stats["steps"]
    assert 300 <= fast.stats["steps"] <= 300 + len(fast.events)
    np.testing.assert_allclose(plain.nodes, fast.nodes, rtol=0, atol=1e-12)


def test_compiled_dop853_agrees_with_scipys():
    """The same tableau and step control: the two runs agree to their tolerance (their step
    sizes part at rounding level, so not bit for bit)."""
    traj = simulate(_line("DOP853"))
    scipy_run = _with_kernels("numpy", lambda: simulate(_line("DOP853")))
    np.testing.assert_allclose(traj.nodes, scipy_run.nodes, rtol=0, atol=1e-10)
    np.testing.assert_allclose(traj.nodes[:, 1, 0], X0 * np.cos(OMEGA * traj.times), atol=1e-9)
    assert abs(traj.stats["steps"] - scipy_run.stats["steps"]) <= 2


def test_rk4_without_a_step_says_so():
    with pytest.raises(SceneError, match="RK4 takes fixed steps of max_step"):
        _line("RK4")
