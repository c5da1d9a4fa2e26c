"""Motor modes through the public scene API: a tension-controlled cable settles at its
commanded tension, a reel-speed motor's rest length moves at the commanded speed until the
end of its range, commands out of a mode's range are refused with one line.

The robot is a tug of war along x: a point mass ``p`` [0.5 kg] between two pinned anchors, a
passive cable ``spring`` (k 200 N/m, rest 0.45 m) from ``a`` and a driven one ``drive``
(k 500 N/m, drawn rest length 0.48 m) to ``b``, 1 m apart (a pinned rod keeps the file a
robot). At rest under a tension ``T`` in ``drive`` the spring carries ``T`` too, so
``x_p = 0.45 + T / 200`` and the drive's rest length is ``(1 - x_p) - T / 500``: numbers
from the statics of two springs in series, not from the code.
"""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.sim import SceneError, SimulationError, compile_scene, load_scene, simulate

TUG = {"name": "tug", "units": "SI",
       "nodes": {"a": [0, 0, 0], "p": [0.5, 0, 0], "b": [1.0, 0, 0], "c": [1.0, 0.01, 0], "d": [0, 0.01, 0]},
       "rods": [{"name": "r", "nodes": ["c", "d"], "mass": 1.0, "radius": 0.01}],
       "pinned": ["a", "b", "c", "d"], "masses": {"p": 0.5},
       "cables": [{"name": "spring", "nodes": ["a", "p"], "stiffness": 200.0, "damping": 5.0, "rest_length": 0.45},
                  {"name": "drive", "nodes": ["p", "b"], "stiffness": 500.0, "damping": 5.0, "rest_length": 0.48,
                   "motor": {"range": [0.2, 0.6], "tau": 0.05, "max_speed": 0.1, "max_tension": 50.0}}]}


def tug_scene(mode, command, duration=3.0):
    return load_scene({"name": "tug", "model": {"kind": "robot", "robot": TUG}, "initial": {"drawn": True},
                       "effects": ["inertia", "cables", {"motors": {"modes": {"drive": mode}}}],
                       "inputs": {"drive": command}, "duration": duration, "output": {"rate": 100}})


@pytest.mark.parametrize("tension", [5.0, 15.0, 40.0])
def test_a_tension_controlled_cable_settles_at_its_commanded_tension(tension):
    """From 10 N as drawn to ``tension`` [N]: after 5 s (a slew at 0.1 m/s of up to 2.1 s, then
    60 motor lags) the drive carries the command, the spring the same, and the mass sits where
    the two springs in series put it."""
    run = simulate(tug_scene("tension", tension, duration=5.0))
    spring, drive = run.member_names.index("spring"), run.member_names.index("drive")
    x = 0.45 + tension / 200.0
    assert abs(run.member_forces[-1, drive] - tension) < 1e-3
    assert abs(run.member_forces[-1, spring] - tension) < 1e-3
    assert abs(run.member_lengths[-1, spring] - x) < 1e-5
    assert abs(run.applied_forces[-1, 0] - ((1.0 - x) - tension / 500.0)) < 1e-5


def test_a_reel_speed_motor_moves_its_rest_length_at_that_speed_until_its_range_ends():
    """Paid out at 0.05 m/s (within its 0.1 m/s slew limit): the drive's rest length is
    ``0.48 + 0.05 t`` [m] on every sample until the range's end (0.6 m, at 2.4 s), then stays."""
    run = simulate(tug_scene("reel_speed", 0.05))
    np.testing.assert_allclose(run.applied_forces[:, 0], np.clip(0.48 + 0.05 * run.times, 0.2, 0.6), rtol=0,
                               atol=1e-12)
    assert run.applied_forces[-1, 0] == 0.6


def test_commands_out_of_a_modes_range_are_refused_with_one_line():
    with pytest.raises(SceneError, match=r"reel speed 0\.5 m/s of cable 'drive' is outside its motor's range "
                                         r"\[-0\.1, 0\.1\] m/s"):
        tug_scene("reel_speed", 0.5)
    with pytest.raises(SceneError, match=r"tension 60 N of cable 'drive' is outside its motor's range \[0, 50\] N"):
        tug_scene("tension", 60.0)
    with pytest.raises(SceneError, match=r"motors\.modes\.spring.*'spring' is not an actuated cable"):
        load_scene({"model": {"kind": "robot", "robot": TUG}, "initial": {"drawn": True}, "effects": ["inertia", "cables", {
            "motors": {"modes": {"spring": "tension"}}}], "duration": 1.0})
    with pytest.raises(SceneError, match=r"must be one of"):
        tug_scene("torque", 1.0)
    model = compile_scene(tug_scene("tension", {"law": "commanded"}))
    state = model.initial_state()
    with pytest.raises(SimulationError, match=r"commanded tension of drive must be within its motor's range "
                                              r"\[0, 50\] N, got -5"):
        model.set_command(state, [-5.0])
    assert model.interface.modes == ("tension",)
    assert state.commands == pytest.approx((10.0,))      # held as drawn: 500 N/m x (0.5 - 0.48) m
