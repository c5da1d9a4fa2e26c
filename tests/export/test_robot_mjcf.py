"""The MJCF document of a robot: what each part becomes, read back with xml.etree (no MuJoCo),
the contact parameters' derivation, and the exporter's one-line refusals."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.export import ExportError, export_mjcf
from tensegrity_core.export.robot_mjcf import CONTACT_IMPEDANCE, DEFAULT_TIMESTEP, contact_parameters
from tensegrity_core.export.sources import load_source
from tensegrity_core.robot.loading import load_robot, robot_from_text, robot_path
from tensegrity_ros.cli import main


def document(name: str) -> ET.Element:
    return ET.fromstring(export_mjcf(load_robot(name)).xml)


def test_the_three_bar_maps_part_by_part():
    robot = load_robot("three_bar")
    root = document("three_bar")
    assert root.find("option").get("integrator") == "implicitfast"
    assert float(root.find("option").get("timestep")) == DEFAULT_TIMESTEP
    assert root.find("compiler").get("inertiafromgeom") == "false"
    rods = root.findall("worldbody/body")
    assert [b.get("name") for b in rods] == [f"rod:{n}" for n in robot.rods.names]
    for i, body in enumerate(rods):
        a, b = robot.rods.ends[i]
        centre = 0.5 * (robot.nodes[a] + robot.nodes[b])
        np.testing.assert_allclose([float(x) for x in body.get("pos").split()], centre, rtol=0, atol=1e-15)
        inertial = body.find("inertial")
        assert float(inertial.get("mass")) == robot.rods.mass[i]
        I_t, I_a = robot.rods.inertia[i]
        assert [float(x) for x in inertial.get("diaginertia").split()] == [I_t, I_t, I_a]
        caps = [g for g in body.findall("geom") if g.get("type") == "sphere"]
        assert {g.get("name") for g in caps} == {f"cap:{robot.node_names[a]}", f"cap:{robot.node_names[b]}"}
    tendons = root.findall("tendon/spatial")
    c = robot.cables
    for i, tendon in enumerate(tendons):
        assert tendon.get("name") == f"cable:{c.names[i]}"
        if c.motor[i] < 0:                              # passive: the tension-only dead band
            assert [float(x) for x in tendon.get("springlength").split()] == [0.0, c.rest_length[i]]
            assert float(tendon.get("stiffness")) == c.stiffness[i]
        else:                                           # driven: no spring of its own
            assert tendon.get("stiffness") is None and tendon.get("damping") is None
    motors = root.findall("actuator/position")
    assert len(motors) == len(robot.motors)
    for j, motor in enumerate(motors):
        i = robot.motors.cable[j]
        assert float(motor.get("kp")) == c.stiffness[i] and float(motor.get("kv")) == c.damping[i]
        assert [float(x) for x in motor.get("forcerange").split()] == [-robot.motors.max_tension[j], 0.0]
        assert float(motor.get("timeconst")) == robot.motors.tau[j]
    pairs = root.findall("contact/pair")
    assert len(pairs) == 2 * len(robot.rods)
    assert {p.get("condim") for p in pairs} == {"3"}
    key = root.find("keyframe/key")
    assert [float(x) for x in key.get("act").split()] == list(c.rest_length[c.actuated])


def test_the_spine_exports_its_vertebrae_and_fixed_base():
    robot = load_robot("spine")
    root = document("spine")
    bodies = [b.get("name") for b in root.findall("worldbody/body")]
    assert bodies == [f"body:{b.name}" for b in robot.bodies if not b.fixed]
    base = next(b for b in robot.bodies if b.fixed)
    world_sites = {s.get("name") for s in root.findall("worldbody/site")}
    assert {f"node:{robot.node_names[i]}" for i in base.nodes} <= world_sites
    assert root.find("option/flag").get("contact") == "disable"      # no floor


@given(k=st.floats(1e3, 1e7), mass=st.floats(0.05, 50.0), load=st.floats(0.1, 1e3),
       d=st.floats(0.05, 0.95))
def test_the_contact_parameters_give_the_hunt_crossley_rest(k, mass, load, d):
    """MuJoCo's contact at rest (docs/mujoco.md): reference acceleration ``k_r d delta`` with
    ``k_r = S/d^2``, regulariser ``R = (1 - d)/d A`` with ``A = 1/m``; the force ``a_ref / R``
    must carry ``load`` at the Hunt-Crossley penetration ``load / k``; and ``D`` damps the
    contact's oscillator ``delta'' + D delta' + S delta`` critically."""
    S, D = contact_parameters(k, mass, d)
    delta = load / k
    a_ref = (S / d**2) * d * delta
    R = (1 - d) / d / mass
    assert math.isclose(a_ref / R, load, rel_tol=1e-12)
    assert math.isclose(D * D, 4 * S, rel_tol=1e-12)
    assert 0 < CONTACT_IMPEDANCE < 1


def test_a_robot_file_and_a_shipped_name_are_sources(tmp_path):
    assert load_source("six_bar").name == "six_bar"
    copy = tmp_path / "my_robot.yaml"
    copy.write_text(robot_path("three_bar").read_text())
    assert load_source(str(copy)).name == "three_bar"


def test_what_a_robot_cannot_export_says_why_in_one_line():
    pinned = robot_path("three_bar").read_text() + "pinned: {s0: [x, y, z]}\n"
    with pytest.raises(ExportError, match=r"^robot 'three_bar': rod end 's0' is pinned; MJCF rods are free bodies"):
        export_mjcf(robot_from_text(pinned))


def test_the_cli_exports_a_shipped_robot(tmp_path, capsys):
    out = tmp_path / "3bar.xml"
    assert main(["export", "mjcf", "three_bar", "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["rods"], summary["tendons"], summary["motors"], summary["contacts"]) == (3, 9, 6, 6)
    assert (summary["nq"], summary["nv"], summary["integrator"]) == (21, 18, "implicitfast")
    assert ET.parse(out).getroot().get("model") == "three_bar"
    assert main(["export", "mjcf", "three_bar", "-o", str(out)]) == 0
    text = capsys.readouterr().out.splitlines()
    assert text[1] == ("  3 rods and 0 rigid bodies on free joints, 0 point-mass nodes on slide joints, 9 cables "
                       "(6 motors), 6 floor contacts, 15 sensors; nq = 21, nv = 18")


def test_a_bad_robot_file_is_one_line_with_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(robot_path("three_bar").read_text().replace("stiffness: 700.0", "stiffness: -700.0", 1))
    assert main(["export", "mjcf", str(bad), "-o", str(tmp_path / "m.xml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "stiffness" in err[0], err
    assert not (tmp_path / "m.xml").exists()


def test_a_robot_scene_exports_with_its_lift_and_effects():
    from tensegrity_core.sim import load_scene

    scene = load_scene("three_bar_drop")
    model = export_mjcf(scene)
    root = ET.fromstring(model.xml)
    # integrated as the project integrates the scene: RK4 at its fixed step
    assert model.name == "three_bar_drop" and (model.integrator, model.timestep) == ("RK4", scene.integrator.max_step)
    robot = scene.model.robot
    lift = scene.initial.lift
    assert lift > 0
    for i, body in enumerate(root.findall("worldbody/body")):
        a, b = robot.rods.ends[i]
        centre = 0.5 * (robot.nodes[a] + robot.nodes[b]) + lift * robot.floor.normal
        np.testing.assert_allclose([float(x) for x in body.get("pos").split()], centre, rtol=0, atol=1e-15)
    assert len(root.findall("contact/pair")) == 2 * len(robot.rods)
    np.testing.assert_array_equal([float(x) for x in root.find("option").get("gravity").split()],
                                  scene.effects["gravity"].vector)


def test_rolling_and_torsional_friction_export_as_condim_6_with_the_same_coefficients():
    """MuJoCo's pair friction is (slide, slide, torsional, rolling, rolling), its torsional and
    rolling coefficients the couples' lever arms [m], as the floor's."""
    from tensegrity_core.sim import load_scene

    floor = load_robot("six_bar").floor
    for source, expected in ((load_robot("six_bar"), (0.9, 0.005, 0.0001)),
                             (load_scene({"name": "s", "model": {"kind": "robot", "robot": "six_bar"},
                                          "initial": {"drawn": True}, "duration": 1.0,
                                          "effects": ["inertia", "cables", "contact", {"friction": {
                                              "rolling_friction": 0.002, "torsional_friction": 0.0}}]}),
                              (floor.mu_static, 0.0, 0.002))):
        pairs = ET.fromstring(export_mjcf(source).xml).findall("contact/pair")
        assert {p.get("condim") for p in pairs} == {"6"}
        mu, torsional, rolling = expected
        for p in pairs:
            assert [float(x) for x in p.get("friction").split()] == [mu, mu, torsional, rolling, rolling]
