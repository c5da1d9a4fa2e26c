"""Gaits: tables of rest lengths over time, periodic, scaled in time; as scene inputs driving
actuators; and one clear line for each bad table."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.robot.gait import GaitError, gait_from_dict
from tensegrity_core.sim import SceneError, load_scene, simulate

TABLE = {"cables": ["a", "b"], "times": [0.0, 1.0, 1.5], "rest_lengths": [[1.0, 2.0], [0.8, 2.0], [0.8, 1.5]],
         "period": 2.0}


def test_a_periodic_gait_repeats_its_table_and_closes_each_cycle():
    gait = gait_from_dict(dict(TABLE, cycles=3, time_scale=0.5, start=0.25))
    laws = gait.laws()
    # one cycle of 2 s scaled to 1 s, from t = 0.25 s; each cycle runs back to the first row
    # at the period; after 3 cycles it holds the first row
    t = np.linspace(0.0, 4.0, 801)
    local = (t - 0.25) / 0.5                       # in the table's own seconds
    phase = np.clip(local, 0.0, 6.0) % 2.0
    phase[local >= 6.0] = 0.0
    a = np.interp(phase, [0.0, 1.0, 1.5, 2.0], [1.0, 0.8, 0.8, 1.0])
    b = np.interp(phase, [0.0, 1.0, 1.5, 2.0], [2.0, 2.0, 1.5, 2.0])
    np.testing.assert_allclose(laws["a"].arrays(t, 0.0)[0], a, atol=1e-12)
    np.testing.assert_allclose(laws["b"].arrays(t, 0.0)[0], b, atol=1e-12)
    assert gait.duration == 3.25
    assert 0.25 + 0.5 in laws["a"].breakpoints and 3.25 in laws["a"].breakpoints


def test_a_held_gait_steps():
    gait = gait_from_dict(dict(TABLE, interpolation="previous"))
    law = gait.laws()["a"]
    assert law.value_at(0.99, 0.0) == 1.0 and law.value_at(1.0, 0.0) == 0.8 and law.value_at(1.99, 0.0) == 0.8
    assert law.value_at(2.0, 0.0) == 1.0                          # the period closes on the first row


@pytest.mark.parametrize("change, message", [
    ({"times": [0.0, 1.0, 1.0]}, "times[2]: times must increase, but 1 s follows 1 s"),
    ({"times": [0.1, 1.0, 1.5]}, "times[0]: the first time must be 0 s, got 0.1"),
    ({"rest_lengths": [[1.0, 2.0], [0.8], [0.8, 1.5]]}, "rest_lengths[1]: must be a list of 2 rest lengths"),
    ({"rest_lengths": [[1.0, 2.0], [0.8, -2.0], [0.8, 1.5]]}, "rest length of 'b' must be > 0 m, got -2"),
    ({"period": 1.5}, "period: must be > 1.5 s, got 1.5 s"),
    ({"period": None, "cycles": 2}, "cycles: 2 cycles need a periodic gait"),
    ({"cables": ["a", "a"]}, "cable 'a' is listed twice"),
    ({"interpolation": "cubic"}, "interpolation: must be one of linear, previous, got 'cubic'"),
    ({"perod": 3.0}, "unknown key 'perod' (did you mean 'period'?)"),
])
def test_bad_tables_are_one_clear_line(change, message):
    data = dict(TABLE, **change)
    data = {k: v for k, v in data.items() if v is not None}
    with pytest.raises(GaitError) as err:
        gait_from_dict(data)
    assert message in str(err.value) and "\n" not in str(err.value)


LINE = {
    "nodes": {"a": [-1.0, 0, 0], "m": [0.0, 0, 0], "b": [1.0, 0, 0]},
    "members": [{"name": "act", "nodes": ["a", "m"], "type": "actuator", "EA": 100.0, "rest_length": 1.0},
                {"name": "bar", "nodes": ["m", "b"], "type": "bar", "EA": 100.0, "rest_length": 1.0}],
    "pinned": {"a": "xyz", "b": "xyz", "m": "yz"},
}


def _scene(inputs):
    return load_scene({"model": {"kind": "general", "structure": LINE}, "initial": {"drawn": True},
                       "effects": ["springs"], "duration": 3.0, "output": {"rate": 20}, "inputs": inputs})


def test_a_gait_drives_actuator_members_in_a_scene():
    gait = {"cables": ["act"], "times": [0.0, 1.0], "rest_lengths": [[1.0], [0.8]], "period": 1.5, "cycles": 2}
    traj = simulate(_scene({"gait": gait}))
    expected = np.interp(np.where(traj.times < 3.0, traj.times % 1.5, 0.0), [0.0, 1.0, 1.5], [1.0, 0.8, 1.0])
    np.testing.assert_allclose(traj.applied_forces[:, 0], expected, atol=1e-12)
    x = traj.nodes[:, 1, 0]                          # the quasi-static balance EA (x + 1 - l0)/l0 = -EA x
    np.testing.assert_allclose((x + 1 - expected) / expected, -x, atol=1e-9)


def test_scene_gait_errors():
    gait = {"cables": ["akt"], "times": [0.0], "rest_lengths": [[1.0]]}
    with pytest.raises(SceneError, match=r"inputs.gait: the gait drives 'akt', which is not an actuator "
                                         r"\(did you mean 'act'\?\); actuators: act"):
        _scene({"gait": gait})
    with pytest.raises(SceneError, match="actuator 'act' has a law and is driven by the gait"):
        _scene({"gait": dict(gait, cables=["act"]), "act": 1.0})
    with pytest.raises(SceneError, match="no gait file .* and no shipped gait 'six_bar_rol'"):
        _scene({"gait": {"file": "six_bar_rol"}})
