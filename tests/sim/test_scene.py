"""Scene files: every shipped scene loads; each kind of error names its key path and line."""

from __future__ import annotations

import textwrap

import pytest

from tensegrity_core.sim import SceneError, load_scene, scene_from_text, scene_names
from tensegrity_core.sim.inputs import Commanded, Proportional, Ramp, Series

GOOD = textwrap.dedent("""\
    name: test scene
    model:
      kind: class2
      params: {k: 1.0, c: 0.01}
    initial:
      equilibrium: {rho1: 0.7, rho2: 0.7}
    inputs:
      f1: {law: proportional, gain: 10.0}
      f2: {law: ramp, from: 0.0, to: 1.0, t0: 0.5, t1: 1.5}
    effects:
      - inertia
      - springs
      - damping
      - fold_limit: {restitution: 0.2}
    output: {rate: 50}
    duration: 2.0
    integrator: {method: DOP853, rtol: 1.0e-7, atol: 1.0e-9}
    seed: 3
    """)


def error(text: str) -> SceneError:
    with pytest.raises(SceneError) as info:
        load_scene(text)
    return info.value


def test_the_shipped_scenes_load():
    names = scene_names()
    assert {"paper_fold", "paper_fold_quasistatic", "stiff_fold", "table_gravity", "spine_release",
            "class2_at_rest"} <= set(names)
    for name in names:
        scene = load_scene(name)
        assert scene.duration > 0 and scene.name == name


def test_a_good_scene_is_read_into_typed_data():
    scene = load_scene(GOOD)
    assert scene.name == "test scene" and scene.output_rate == 50 and scene.seed == 3
    assert list(scene.effects) == ["inertia", "springs", "damping", "fold_limit"]
    assert scene.effects["fold_limit"].restitution == 0.2
    assert isinstance(scene.inputs["f1"], Proportional) and scene.inputs["f1"].gain == 10.0
    assert isinstance(scene.inputs["f2"], Ramp) and scene.inputs["f2"].breakpoints == (0.5, 1.5)
    assert scene.initial.lengths == (0.7, 0.7) and not scene.quasi_static
    assert scene.integrator.method == "DOP853" and scene.integrator.rtol == 1e-7


def test_dicts_paths_and_names_are_accepted(tmp_path):
    import yaml

    path = tmp_path / "s.yaml"
    path.write_text(GOOD)
    assert load_scene(path).name == load_scene(str(path)).name == load_scene(yaml.safe_load(GOOD)).name


@pytest.mark.parametrize("text, key, line, words", [
    (GOOD.replace("seed: 3", "sede: 3"), "sede", 18, "unknown key 'sede' (did you mean 'seed'?)"),
    (GOOD.replace("params: {k: 1.0, c: 0.01}", "params: {k: 1.0, kk: 2}"), "model.params.kk", 4, "unknown key"),
    (GOOD.replace("duration: 2.0\n", ""), "", 1, "missing required key 'duration'"),
    (GOOD.replace("equilibrium: {rho1: 0.7, rho2: 0.7}", "equilibrium: {rho1: 0.7}"),
     "initial.equilibrium", 6, "missing required key 'rho2'"),
    (GOOD.replace("duration: 2.0", "duration: two"), "duration", 16, "must be a number"),
    (GOOD.replace("duration: 2.0", "duration: -1"), "duration", 16, "must be > 0"),
    (GOOD.replace("{restitution: 0.2}", "{restitution: 1.5}"), "effects[3].fold_limit.restitution", 14,
     "must be <= 1"),
    (GOOD.replace("  - damping\n", "  - dampng\n"), "effects[2]", 13, "unknown effect 'dampng'"),
    (GOOD.replace("  - damping\n", "  - springs\n"), "effects[2]", 13, "listed twice"),
    (GOOD.replace("rho1: 0.7, rho2: 0.7", "rho1: 1.2, rho2: 0.1"), "initial.equilibrium", 6, "below L"),
    (GOOD.replace("rho1: 0.7, rho2: 0.7", "rho1: -0.1, rho2: 0.7"), "initial.equilibrium", 6, ">= 0 with the fold"),
    (GOOD.replace("law: proportional", "law: linear"), "inputs.f1.law", 8, "must be one of"),
    (GOOD.replace("t0: 0.5, t1: 1.5", "t0: 0.5, t1: 0.2"), "inputs.f2.t1", 9, "must be after t0"),
    (GOOD.replace("  f2: {law: ramp, from: 0.0, to: 1.0, t0: 0.5, t1: 1.5}\n", ""), "inputs", 8,
     "missing required key 'f2'"),
    (GOOD.replace("method: DOP853", "method: Euler"), "integrator.method", 17, "must be one of"),
    (GOOD.replace("rtol: 1.0e-7", "rtol: 1.0e-20"), "integrator.rtol", 17, "must be >= 1e-13"),
    (GOOD.replace("seed: 3", "seed: -3"), "seed", 18, "non-negative integer"),
    (GOOD.replace("output: {rate: 50}", "output: {rate: 0}"), "output.rate", 15, "must be > 0"),
    (GOOD.replace("  - inertia\n", ""), "effects[1]", 12, "needs 'inertia'"),
    (GOOD.replace("  - fold_limit: {restitution: 0.2}", "  - loads: {G: [1, 0, 0]}"), "effects[3].loads.G", 14,
     "unknown node 'G'"),
    (GOOD.replace("  - fold_limit: {restitution: 0.2}", "  - sensor_noise: {q: -1}"), "effects[3].sensor_noise.q",
     14, "must be >= 0"),
    (GOOD.replace("  - fold_limit: {restitution: 0.2}", "  - actuator_lag: {tau: 0}"),
     "effects[3].actuator_lag.tau", 14, "must be > 0"),
    (GOOD.split("effects:")[0] + "effects: 3\nduration: 1.0\n", "effects", 10, "must be a list"),
    (GOOD.replace("kind: class2", "kind: class3"), "model.kind", 3, "must be one of class2, general"),
    (GOOD.replace("params: {k: 1.0, c: 0.01}", "params: {k: -1.0, c: 0.01}"), "model.params.k", 4, "must be > 0"),
    (GOOD.replace("params: {k: 1.0, c: 0.01}", "params: {k: 1.0, c: -0.01}"), "model.params.c", 4, "must be >= 0"),
    (GOOD.replace("f1: {law: proportional, gain: 10.0}", "f1: {law: commanded, initial: keep}"),
     "inputs.f1.initial", 8, "must be a number or 'hold', got 'keep'"),
    (GOOD.replace("f1: {law: proportional, gain: 10.0}", "f1: {law: commanded, initial: hld}"),
     "inputs.f1.initial", 8, "(did you mean 'hold'?)"),
])
def test_each_kind_of_error_names_the_key_and_the_line(text, key, line, words):
    err = error(text)
    assert err.key == tuple(_parse_key(key)) if key else err.key == ()
    assert err.line == line, str(err)
    assert words in str(err)
    if key:
        assert str(err).startswith(f"{key}: ")
    if line:
        assert str(err).endswith(f"(line {line})")


def _parse_key(key: str):
    out = []
    for part in key.replace("]", "").split("."):
        name, _, index = part.partition("[")
        out.append(name)
        if index:
            out.append(int(index))
    return out


def test_the_file_name_leads_the_message(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text(GOOD.replace("seed: 3", "seed: 3\nseed: 4"))
    err = error(str(path))
    assert str(err).startswith("broken.yaml: ") and "duplicate key 'seed'" in str(err) and err.line == 19


@pytest.mark.parametrize("text", ["", "# only a comment\n", "~\n"])
def test_an_empty_scene_is_named_as_nothing(text):
    with pytest.raises(SceneError) as info:
        scene_from_text(text)
    assert str(info.value) == "must be a mapping, got nothing (null)"


def test_invalid_yaml_reports_its_line():
    err = error(GOOD.replace("params: {k: 1.0, c: 0.01}", "params: {k: 1.0, c: 0.01"))
    assert "invalid YAML" in str(err) and err.line is not None


def test_unknown_names_and_missing_files_are_rejected(tmp_path):
    with pytest.raises(SceneError, match=r"neither a shipped scene \(did you mean 'paper_fold'\?\)"):
        load_scene("paper_flod")
    with pytest.raises(SceneError, match="scene file not found"):
        load_scene(str(tmp_path / "nothing.yaml"))


def test_series_inputs_are_read_from_csv_relative_to_the_scene(tmp_path):
    (tmp_path / "forces.csv").write_text("t,f\n0,0\n1,2\n2,2\n")
    text = GOOD.replace("f1: {law: proportional, gain: 10.0}", "f1: {law: series, file: forces.csv, column: f}")
    path = tmp_path / "s.yaml"
    path.write_text(text)
    law = load_scene(path).inputs["f1"]
    assert isinstance(law, Series) and law.value_at(0.5, 0.0) == 1.0 and law.breakpoints == (0.0, 1.0, 2.0)
    (tmp_path / "bad.csv").write_text("t,f\n0,0\n1,2\n1,3\n")
    path.write_text(text.replace("forces.csv", "bad.csv"))
    err = error(str(path))
    assert err.key == ("inputs", "f1", "file") and "times must increase" in str(err) and err.line == 8
    path.write_text(text.replace("column: f", "column: g"))
    err = error(str(path))
    assert err.key == ("inputs", "f1", "column") and "no column 'g'" in str(err)
    path.write_text(text.replace("forces.csv", "missing.csv"))
    assert "CSV file not found" in str(error(str(path)))


def test_general_scenes_check_their_structure_and_effects():
    text = textwrap.dedent("""\
        model: {kind: general, structure: tensegrity_table, end_effector: c1}
        initial: {equilibrium: {preload: {c1: [0, 0, -10]}}}
        effects: [springs, gravity, {loads: {hang: [0, 0, -1]}}]
        duration: 1.0
        """)
    scene = load_scene(text)
    assert scene.quasi_static and scene.model.end_effector == scene.model.structure.node_names.index("c1")
    err = error(text.replace("end_effector: c1", "end_effector: c11"))
    assert err.key == ("model", "end_effector") and "did you mean 'c1'" in str(err) and err.line == 1
    err = error(text.replace("[springs, gravity,", "[springs, fold_limit,"))
    assert err.key == ("effects", 1) and "class-2 mechanism only" in str(err)
    # its options are not read as the class-2 drive's (it has no default stiffness here)
    err = error(text.replace("[springs, gravity,", "[inertia, springs, {actuator_compliance: {drive_damping: 1}},"))
    assert err.key == ("effects", 2) and "class-2 mechanism only" in str(err)
    err = error(text.replace("structure: tensegrity_table", "structure: tensegrity_tabel"))
    assert "did you mean 'tensegrity_table'" in str(err)
    err = error(text.replace("{c1: [0, 0, -10]}", "{c0: [0, 0, -10]}"))
    assert err.key == ("initial", "equilibrium", "preload", "c0")
    err = error(text.replace("effects: [springs, gravity,", "effects: [gravity,"))
    assert "needs 'springs'" in str(err)


def test_commanded_inputs_hold_by_default():
    scene = load_scene(GOOD.replace("f1: {law: proportional, gain: 10.0}", "f1: {law: commanded}"))
    assert isinstance(scene.inputs["f1"], Commanded) and scene.inputs["f1"].initial is None


def test_output_that_would_not_fit_in_memory_is_refused_before_the_run():
    # 1e9 Hz for 2 s: 2e9 samples of 64 values (class-2) = 1.0e12 bytes, beyond the 2 GiB bound
    err = error(GOOD.replace("output: {rate: 50}", "output: {rate: 1.0e9}"))
    assert err.key == ("output", "rate") and err.line == 15
    assert "gives 2e+09 samples of 64 values, 1.02e+12 bytes, more than the 2 GiB" in str(err)
    err = error(GOOD.replace("output: {rate: 50}\n", "").replace("duration: 2.0", "duration: 1.0e9"))
    assert err.key == ("duration",) and "samples" in str(err)
    scene = load_scene(GOOD)
    with pytest.raises(SceneError, match="samples of 64 values"):
        scene.with_duration(1e12)
    with pytest.raises(SceneError, match=r"duration: must be at most 1e\+15 s in magnitude, got 1e\+300 s"):
        scene.with_duration(1e300)
    assert scene.with_duration(3.0).duration == 3.0


@pytest.mark.parametrize("old, new, key", [
    ("params: {k: 1.0, c: 0.01}", "params: {k: 1.0, c: 0.01, L: 1.0e300}", "model.params.L"),
    ("duration: 2.0", "duration: 1.0e300", "duration"),
    ("gain: 10.0", "gain: -1.0e16", "inputs.f1.gain"),
])
def test_extreme_numbers_are_refused_by_name(old, new, key):
    err = error(GOOD.replace(old, new))
    assert str(err).startswith(f"{key}: must be ") and len(str(err)) < 120


def test_scene_text_is_never_taken_for_a_file_name(tmp_path):
    from tensegrity_core.sim import scene_from_text

    path = tmp_path / "s.yaml"
    path.write_text(GOOD)
    with pytest.raises(SceneError, match="must be a mapping, got a string"):
        scene_from_text(str(path))
    assert scene_from_text(GOOD).name == "test scene"
