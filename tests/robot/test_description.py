"""Robot descriptions: the shipped robots (generated files, counts, prestressed rest shapes on
the robot's own cable element) and one clear line for each bad input."""

from __future__ import annotations

import copy
import math
from dataclasses import replace

import numpy as np
import pytest
import yaml

from tensegrity_core.general import load_example, member_forces
from tensegrity_core.general.writing import dump_description
from tensegrity_core.robot import cable, generators
from tensegrity_core.robot.description import RobotError
from tensegrity_core.robot.loading import load_robot, robot_from_file, robot_from_text, robot_names, robot_path
from tensegrity_core.robot.robot_schema import robot_from_dict
from tensegrity_core.robot.statics import rest_shape

GENERATORS = {"three_bar": generators.three_bar, "six_bar": generators.six_bar, "spine": generators.spine}


def _same_data(shipped, generated, where="") -> None:
    """Equal keys, lengths, strings and integers; floats within 1e-9 relative (1e-12 absolute
    near zero): the generators' last digits follow the machine's BLAS and numpy's SIMD trig
    kernels (an AMD machine's OpenBLAS wrote 0.17417599055634925 where an Intel one wrote
    0.1741759905563493), while a hand edit of a shipped file changes far more than that."""
    if isinstance(shipped, float) or isinstance(generated, float):
        assert math.isclose(shipped, generated, rel_tol=1e-9, abs_tol=1e-12), (where, shipped, generated)
    elif isinstance(shipped, dict):
        assert isinstance(generated, dict) and list(shipped) == list(generated), where
        for key in shipped:
            _same_data(shipped[key], generated[key], f"{where}.{key}")
    elif isinstance(shipped, list):
        assert isinstance(generated, list) and len(shipped) == len(generated), where
        for i, (a, b) in enumerate(zip(shipped, generated)):
            _same_data(a, b, f"{where}[{i}]")
    else:
        assert type(shipped) is type(generated) and shipped == generated, (where, shipped, generated)


@pytest.mark.parametrize("name", sorted(GENERATORS))
def test_shipped_files_are_the_generators_output(name):
    _same_data(yaml.safe_load(robot_path(name).read_text()), yaml.safe_load(dump_description(GENERATORS[name]())))


def test_a_changed_digit_of_a_shipped_file_is_seen():
    data = yaml.safe_load(dump_description(generators.three_bar()))
    edited = copy.deepcopy(data)
    edited["nodes"]["s0"][2] *= 1 + 1e-8          # a hand edit in the ninth digit
    _same_data(data, copy.deepcopy(data))
    with pytest.raises(AssertionError):
        _same_data(edited, data)


def test_the_shipped_robots_have_the_issue_s_parts():
    tb = load_robot("three_bar")
    assert (len(tb.rods), len(tb.motors), len(tb.cables) - len(tb.motors)) == (3, 6, 3)
    assert len(tb.sensors.cable_length) == 9 and len(tb.sensors.imu_rods) == 2
    sb = load_robot("six_bar")
    assert (len(sb.rods), len(sb.cables), len(sb.motors)) == (6, 24, 24)
    assert sorted(np.bincount(sb.cables.ends.ravel(), minlength=12)) == [4] * 12   # four cables at every cap
    assert load_robot("spine").floor is None and len(load_robot("spine").motors) == 36
    assert robot_names() == ["six_bar", "spine", "three_bar"]


def test_three_bar_parameters_are_the_mujoco_model_s():
    """The MuJoCo actuator F = 6667 a + 3290 - 6666 L - 133 Ldot, clamped to [-267, 0], for
    a in [-0.45, 0.15]: stiffness 6666 N/m, damping 133 N s/m, rest length 3290/6666 + a."""
    tb = load_robot("three_bar")
    act = tb.cables.actuated
    np.testing.assert_allclose(tb.cables.stiffness[act], 6666.0)
    np.testing.assert_allclose(tb.cables.damping[act], 133.0)
    np.testing.assert_allclose(tb.motors.range, [[3290 / 6666 - 0.45, 3290 / 6666 + 0.15]] * 6)
    np.testing.assert_allclose(tb.motors.max_tension, 267.0)
    np.testing.assert_allclose(tb.rod_lengths(), 1.376, rtol=1e-15)
    # the composite inertia of the model's geoms, summed here from their closed forms
    tube = 1.0 * (1.376**2 / 12 + 0.0381**2 / 4)
    housing = 2 * (1.0 * (0.45**2 / 12 + 0.035**2 / 4) + 1.0 * 0.463**2)
    caps = 2 * 0.5 * (0.688**2 + 0.4 * 0.0675**2)
    np.testing.assert_allclose(tb.rods.inertia[0], [tube + housing + caps,
                                                    0.0381**2 / 2 + 0.035**2 + 0.4 * 0.0675**2], rtol=1e-12)


@pytest.mark.parametrize("name", ["three_bar", "six_bar", "spine"])
def test_rest_shapes_are_prestressed_stable_equilibria_of_the_cable_element(name):
    robot = load_robot(name)
    result = rest_shape(robot, gravity=name == "spine")
    assert result.success and result.stable, result.message
    X = result.nodes
    e = robot.cables.ends
    l = np.linalg.norm(X[e[:, 1]] - X[e[:, 0]], axis=1)
    T = cable.tension(l, 0.0, robot.cables.rest_length, robot.cables.stiffness, 0.0)
    np.testing.assert_allclose(result.member_forces[robot.cable_members()], T, rtol=1e-9, atol=1e-9)
    if name != "spine":
        assert T.min() > 0.0                                        # every cable taut: prestressed
    rods = robot.rods.ends
    np.testing.assert_allclose(np.linalg.norm(X[rods[:, 1]] - X[rods[:, 0]], axis=1), robot.rod_lengths(), rtol=1e-5)


def test_six_bar_rest_shape_is_the_regular_expanded_octahedron():
    """Equal cables: nodes at (0, +-L/4, +-L/2) and cyclic, cables sqrt(6) L / 4 long for rods
    of length L (here the statics' rods, 1.1e-5 m shorter than drawn: 441 N of compression on
    a bar of EA/L = 1e4 x 4000 N/m), each at k (sqrt(6) L / 4 - l0) = 180.1 N."""
    robot = load_robot("six_bar")
    X = rest_shape(robot).nodes
    e, r = robot.cables.ends, robot.rods.ends
    l = np.linalg.norm(X[e[:, 1]] - X[e[:, 0]], axis=1)
    L = np.linalg.norm(X[r[:, 1]] - X[r[:, 0]], axis=1)
    np.testing.assert_allclose(L, L[0], rtol=1e-12)
    assert 0 < 1.7 - L[0] < 2e-5
    np.testing.assert_allclose(l, math.sqrt(6) * L[0] / 4, rtol=1e-10)


def test_spine_is_spine_release_s_structure_drawn_at_rest():
    """The spine's cords are spine_c's (rest lengths, EA = 500 N: equal forces at spine_c's
    drawing) and it is drawn at their weightless equilibrium: the cords' net force and moment
    on every free vertebra vanish (summed here from the cords' tensions), where spine_c's
    drawing leaves them unbalanced by up to 338 N."""
    robot = load_robot("spine")
    spine = robot.structure()
    cords = load_example("spine_c").replace(EA=np.full(spine.n_members, 500.0))
    np.testing.assert_allclose(spine.rest_lengths, cords.rest_lengths)
    np.testing.assert_allclose(member_forces(spine, cords.nodes), member_forces(cords, cords.nodes), rtol=1e-12)

    def unbalanced(X):
        e, l0 = robot.cables.ends, robot.cables.rest_length
        d = X[e[:, 1]] - X[e[:, 0]]
        l = np.linalg.norm(d, axis=1)
        pull = (np.maximum(500.0 * (l - l0) / l0, 0.0) / l)[:, None] * d      # on end 0, towards end 1
        F = np.zeros_like(X)
        np.add.at(F, e[:, 0], pull)
        np.add.at(F, e[:, 1], -pull)
        worst = 0.0
        for body in spine.bodies:
            if not body.fixed:
                n = list(body.nodes)
                moment = np.cross(X[n] - X[n].mean(axis=0), F[n]).sum(axis=0)
                worst = max(worst, np.abs(F[n].sum(axis=0)).max(), np.abs(moment).max() / 0.1)
        return worst
    assert unbalanced(cords.nodes) > 10.0 and unbalanced(robot.nodes) < 1e-6


def _tb() -> dict:
    return copy.deepcopy(generators.three_bar())


def _error(data) -> str:
    with pytest.raises(RobotError) as err:
        robot_from_dict(data)
    text = str(err.value)
    assert "\n" not in text and "Traceback" not in text
    return text


def test_bad_input_one_clear_line_each():
    d = _tb()
    d["cables"][0]["rest_length"] = 0.9
    assert _error(d) == ("cables[0].rest_length: cable 'td_0': rest length 0.9 m is outside the motor's "
                         "range [0.0435494, 0.643549] m")
    d = _tb()
    d["cables"][6]["stiffness"] = math.nan
    assert _error(d) == "cables[6].stiffness: must be finite, got nan"
    d = _tb()
    d["cables"][7]["stiffness"] = -700.0
    assert _error(d) == "cables[7].stiffness: must be > 0 N/m, got -700.0 N/m"
    d = _tb()
    d["nodes"]["s1"] = list(d["nodes"]["s0"])
    assert "rod 'r01' has zero length: nodes 's0' and 's1' are both at" in _error(d)
    d = _tb()
    d["floor"]["mu_static"] = -0.2
    assert _error(d) == "floor.mu_static: must be >= 0 (dimensionless), got -0.2"
    d = _tb()
    d["floor"]["point"] = [0.0, 0.0, 0.1]
    assert "cap 's3' of rod 'r23' starts 0.1 m inside the floor" in _error(d)


def test_unknown_keys_are_named_with_a_suggestion():
    d = _tb()
    d["cables"][2]["stifness"] = 5.0
    assert "cables[2].stifness: unknown key 'stifness' (did you mean 'stiffness'?)" in _error(d)
    d = _tb()
    d["flor"] = d.pop("floor")
    assert "unknown key 'flor' (did you mean 'floor'?)" in _error(d)
    d = _tb()
    d["cable_defaults"]["motor"]["tua"] = 0.1
    assert "cable_defaults.motor.tua: unknown key 'tua' (did you mean 'tau'?)" in _error(d)


def test_more_bad_input():
    d = _tb()
    d["rods"][1]["nodes"] = ["s0", "s3"]
    assert "node 's0' is already an end of rod 'r01'" in _error(d)
    d = _tb()
    d["cables"][0]["nodes"] = ["s0", "s9"]
    assert _error(d) == "cables[0].nodes: cable 'td_0': unknown node 's9'"
    d = _tb()
    d["floor"]["mu_kinetic"] = 1.5
    assert "kinetic friction 1.5 exceeds static friction 1" in _error(d)
    d = _tb()
    d["rods"][0]["inertia"] = [0.1, 0.5]
    assert "I_axial <= 2 I_transverse" in _error(d)
    d = _tb()
    del d["rods"][0]["inertia"]
    d["rods"][0]["radius"] = 0.0
    d["rods"][0]["cap_radius"] = 0.05
    assert "has no inertia about its axis" in _error(d)
    d = _tb()
    d["sensors"]["imu"] = ["r02"]
    assert _error(d) == "sensors.imu[0]: unknown rod or rigid body 'r02' (did you mean 'r23'?)"
    d = _tb()
    d["cables"][8]["name"] = "r45"
    assert "name 'r45' is used twice" in _error(d)
    d = _tb()
    d["cable_defaults"]["motor"]["range"] = [0.6, 0.2]
    assert "the range must be 0 < lo < hi" in _error(d)


def test_errors_carry_the_file_and_line(tmp_path):
    text = robot_path("three_bar").read_text().replace("mu_static: 1.0", "mu_static: -1.0")
    path = tmp_path / "tb.yaml"
    path.write_text(text)
    with pytest.raises(RobotError) as err:
        robot_from_file(path)
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "mu_static" in s)
    assert str(err.value) == f"tb.yaml: floor.mu_static: must be >= 0 (dimensionless), got -1.0 (line {line})"
    with pytest.raises(RobotError, match="unknown robot|no shipped robot"):
        load_robot("three_bars")
    assert robot_from_text(robot_path("six_bar").read_text()).name == "six_bar"


def test_the_statics_of_cables_up_to_1e15_n_per_m_are_those_of_the_shipped_six_bar_scaled():
    """Equilibria are homogeneous in stiffness: the six-bar with every cable 2.5e11 times
    stiffer (1e15 N/m, the largest a description takes; its rods' stand-ins 1.7e19 N, beyond
    the structure format's 1e15) has the same weightless rest shape, every force 2.5e11 times
    larger (the structure's force unit a power of two: its division is exact). A free
    robot's rest shape is found up to a rigid motion (six free modes), so its members'
    lengths are compared: to rounding, 1e-12 m."""
    robot = load_robot("six_bar")
    factor = 1e15 / float(robot.cables.stiffness.max())
    stiff = replace(robot, cables=replace(robot.cables, stiffness=robot.cables.stiffness * factor))
    assert stiff.force_unit() > 1.0 and stiff.structure().EA.max() <= 1e15
    a, b = rest_shape(robot), rest_shape(stiff)
    np.testing.assert_allclose(b.member_lengths, a.member_lengths, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.member_forces, factor * a.member_forces, rtol=1e-9)
