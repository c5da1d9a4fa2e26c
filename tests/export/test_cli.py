"""``tensegrity export mjcf``: as a user runs it, and its one-line errors."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from tensegrity_core.general import load_example
from tensegrity_core.general.writing import save_structure
from tensegrity_ros.cli import main


def test_the_executable_writes_a_model_that_mujoco_loads(tmp_path):
    out = tmp_path / "table.xml"
    done = subprocess.run([str(Path(sys.executable).with_name("tensegrity")), "export", "mjcf", "table_gravity",
                           "-o", str(out)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0] == f"wrote {out}: MuJoCo model of 'table_gravity'"
    assert re.search(r"time step [0-9.e-]+ s \(fastest rate of the linearised dynamics [0-9.]+ 1/s\)", done.stdout)
    mujoco = pytest.importorskip("mujoco", reason="the mujoco extra is not installed (./run setup installs it)")
    model = mujoco.MjModel.from_xml_path(str(out))
    assert (model.nq, model.nv, model.ntendon, model.nu, model.nkey) == (7, 6, 4, 1, 1)


def test_json_summary_and_a_structure_file(tmp_path, capsys):
    structure = tmp_path / "table.yaml"
    save_structure(load_example("tensegrity_table").replace(
        node_masses=[1.0] * 8), structure)
    out = tmp_path / "t.xml"
    assert main(["export", "mjcf", str(structure), "-o", str(out), "--timestep", "0.001", "--integrator",
                 "implicitfast", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["timestep"] == 0.001 and summary["integrator"] == "implicitfast"
    assert (summary["rigid_bodies"], summary["tendons"], summary["nq"], summary["nv"]) == (2, 4, 14, 12)
    assert ET.parse(out).getroot().find("option").get("integrator") == "implicitfast"


@pytest.mark.parametrize("args, message", [
    (["nope"], "error: no scene, robot or structure file 'nope' and no shipped scene or robot or example 'nope'; "
               "shipped scenes: "),
    (["six_bars"], "(did you mean 'six_bar'?)"),
    (["spine_relase"], "(did you mean 'spine_release'?)"),
    (["paper_fold"], "error: scene 'paper_fold' simulates the class-2 mechanism; only general structures export"),
    (["t_bar"], "error: structure 'T-bar': inertia needs a mass on every free node"),
    (["tensegrity_table"], "inertia needs mass on every moving rigid body; 'bottom', 'top' have none (give "),
    (["pyproject.toml"], "error: pyproject.toml: structure: unknown key 'build-system'"),
    (["README.md"], "error: cannot tell what 'README.md' is: a scene file ends in .yaml or .yml"),
    (["table_gravity", "--timestep", "0"], "error: timestep must be a positive number of seconds, got 0.0"),
    (["table_gravity", "--integrator", "rk4"], "error: integrator must be one of RK4, Euler, implicit, implicitfast"),
])
def test_bad_input_is_one_line_with_exit_2(args, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(os.path.dirname(os.path.dirname(os.path.dirname(__file__))))
    out = tmp_path / "m.xml"
    assert main(["export", "mjcf", *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_a_scene_file_that_is_not_a_structure_says_both(tmp_path, capsys):
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text("base: table_gravity\ncompute: final_state\n")
    assert main(["export", "mjcf", str(sweep), "-o", str(tmp_path / "m.xml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: sweep.yaml: structure: unknown key 'base'")
    assert err[0].endswith("(read as a structure: it has no 'model' key, so it is no scene, and no 'cables' key, "
                           "so it is no robot)")


@pytest.mark.parametrize("output, message", [
    ("m.txt", "-o/--output must end in .xml, got"),
    ("missing/m.xml", "does not exist"),
])
def test_bad_output_paths_are_one_line_with_exit_2(output, message, tmp_path, capsys):
    assert main(["export", "mjcf", "table_gravity", "-o", str(tmp_path / output)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_an_output_that_is_a_folder(tmp_path, capsys):
    (tmp_path / "m.xml").mkdir()
    assert main(["export", "mjcf", "table_gravity", "-o", str(tmp_path / "m.xml")]) == 2
    assert capsys.readouterr().err.strip() == f"error: cannot write {str(tmp_path / 'm.xml')!r}: it is a folder"
