"""A scene's references to other files, resolved relative to the scene's folder."""

from __future__ import annotations

import pytest

from tensegrity_core.robot.gait import GAITS_DIR
from tensegrity_core.sim import SceneError
from tensegrity_core.sim.scene.references import self_contained


def test_a_self_contained_scene_inlines_its_structure_and_names_its_files_absolutely(tmp_path, monkeypatch):
    (tmp_path / "bar.yaml").write_text("nodes: {a: [0, 0, 0], b: [1, 0, 0]}\nmembers: [{name: ab, nodes: [a, b]}]\n")
    (tmp_path / "gait.yaml").write_text("cables: [ab]\ntimes: [0.0]\nrest_lengths: [[1.0]]\n")
    doc = {"model": {"kind": "general", "structure": "bar.yaml"},
           "inputs": {"ab": {"law": "series", "file": "table.csv"}, "gait": {"file": "gait.yaml", "cycles": 2}}}
    monkeypatch.chdir("/")                                  # nothing relative to the current folder
    out = self_contained(doc, tmp_path)
    assert out["model"]["structure"] == {"name": "bar", "nodes": {"a": [0, 0, 0], "b": [1, 0, 0]},
                                         "members": [{"name": "ab", "nodes": ["a", "b"]}]}
    assert out["inputs"]["ab"]["file"] == str(tmp_path.resolve() / "table.csv")
    assert out["inputs"]["gait"] == {"file": str(tmp_path.resolve() / "gait.yaml"), "cycles": 2}
    assert doc["model"]["structure"] == "bar.yaml" and doc["inputs"]["gait"]["file"] == "gait.yaml"   # a copy


def test_shipped_names_resolve_to_the_shipped_files_and_a_missing_one_is_named(tmp_path):
    out = self_contained({"inputs": {"gait": {"file": "six_bar_roll"}}}, tmp_path)
    assert out["inputs"]["gait"]["file"] == str((GAITS_DIR / "six_bar_roll.yaml").resolve())
    with pytest.raises(SceneError, match="no shipped gait 'six_bar_rol' \\(did you mean 'six_bar_roll'\\?\\)"):
        self_contained({"inputs": {"gait": {"file": "six_bar_rol"}}}, tmp_path)


def test_a_robot_named_by_a_scene_is_inlined_with_its_name(tmp_path):
    import yaml

    from tensegrity_core.robot.loading import robot_path

    out = self_contained({"model": {"kind": "robot", "robot": "three_bar"}}, tmp_path)
    expected = yaml.safe_load(robot_path("three_bar").read_text())
    expected.setdefault("name", "three_bar")
    assert out["model"]["robot"] == expected
    with pytest.raises(SceneError, match="no shipped robot 'three_bars' \\(did you mean 'three_bar'\\?\\)"):
        self_contained({"model": {"kind": "robot", "robot": "three_bars"}}, tmp_path)
