"""Sweep files: what they accept, what they refuse (with the key path, a suggestion and the
line), and the points they define."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from tensegrity_core.schema import KeyPathError, parse_pattern, resolve
from tensegrity_core.sweep import SweepError, load_sweep, sweep_names
from tensegrity_core.sweep.points import apply
from tests.sweep.conftest import fold_sweep, monte_carlo_sweep

GOOD = textwrap.dedent("""\
    name: t
    base: {scene: paper_fold}
    vary:
      model.params.k: {grid: {from: 0.5, to: 2.0, num: 4}}
      model.params.c: {values: [0.0, 0.01]}
    compute: simulate
    results:
      - first_event_time: {kind: fold}
    """)


def line_of(text: str, needle: str) -> int:
    """1-based line of the first line containing ``needle`` (the test's own count)."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


def error_of(text: str) -> SweepError:
    with pytest.raises(SweepError) as info:
        load_sweep(text)
    return info.value


@pytest.mark.parametrize("old, new, needle, expected", [
    ("compute: simulate", "compute: simulate\nsede: 3", "sede", "unknown key 'sede' (did you mean 'seed'?)"),
    ("model.params.k:", "model.param.k:", "model.param.k",
     "model has no key 'param' (did you mean 'params'?)"),
    ("kind: fold", "kind: folds", "kind: folds", "must be one of any, fold, release"),
    ("first_event_time:", "first_event_tim:", "first_event_tim", "unknown result 'first_event_tim' of 'simulate' (did you mean 'first_event_time'?)"),
    ("first_event_time:", "run_tim:", "run_tim", "unknown result 'run_tim' of 'simulate' (did you mean 'run_time'?)"),
    ("first_event_time: {kind: fold}", "run_time: {kind: fold}", "run_time", "run_time takes no options"),
    ("compute: simulate", "compute: simulat", "compute:", "unknown computation 'simulat' (did you mean 'simulate'?)"),
    ("compute: simulate", "compute: form_find", "compute:", "needs a structure as its base"),
    ("num: 4", "num: 0", "num: 0", "must be an integer >= 1"),
    ("{scene: paper_fold}", "{scene: paper_flod}", "base:", "no shipped scene 'paper_flod' (did you mean 'paper_fold'?)"),
    ("{values: [0.0, 0.01]}", "{values: [0.0, .nan]}", "model.params.c", "values must be numbers"),
    ("{values: [0.0, 0.01]}", "{vals: [0.0, 0.01]}", "model.params.c", "unknown key 'vals' (did you mean 'values'?)"),
    ("{grid: {from: 0.5, to: 2.0, num: 4}}", "{grid: {from: 0.5, to: 2.0, num: 4, spacing: lin}}", "model.params.k",
     "must be one of linear, log, got 'lin' (did you mean 'linear'?)"),
    ("{values: [0.0, 0.01]}", "{normal: {mean: 1.0, std: 0.05}}", "compute: simulate",
     "random quantities need 'samples'"),
    ("model.params.c:", "model.params.cc:", "model.params.cc",
     "has no 'model.params.cc' and takes none of its values there: model.params.cc: unknown key 'cc' "
     "(did you mean 'c'?)"),
])
def test_bad_sweep_files_name_the_key_the_line_and_a_suggestion(old, new, needle, expected):
    text = GOOD.replace(old, new)
    assert text != GOOD
    err = error_of(text)
    assert expected in str(err)
    if "random quantities" not in expected:   # that one is about the whole file (its vary)
        assert err.line == line_of(text, needle), str(err)
        assert f"(line {err.line})" in str(err)


@pytest.mark.parametrize("compute, base, result", [("simulate", {"scene": "paper_fold"}, "t_end"),
                                                     ("form_find", {"structure": "spine_c"}, "stable"),
                                                     ("stiffness", {"structure": "spine_c"}, "rank"),
                                                     ({"ik": {"targets": [[1.0, 0.5]]}}, {"scene": "paper_fold"},
                                                      "reachable")])
def test_run_time_may_be_listed_for_every_computation_and_changes_nothing(compute, base, result):
    """Every row has the point's run time; listing it (as the issue's list of results does)
    is accepted, alone or with others, and leaves the sweep as it was (same results, same id)."""
    vary = {"model.params.k": [1.0]} if "scene" in base else {"members[side*].rest_length": [0.03]}
    doc = {"base": base, "vary": vary, "compute": compute}
    plain = load_sweep({**doc, "results": [result]})
    listed = load_sweep({**doc, "results": ["run_time", result]})
    assert [r[:2] for r in listed.results] == [r[:2] for r in plain.results] == [(result, {})]
    assert listed.sweep_id == plain.sweep_id
    assert load_sweep({**doc, "results": ["run_time"]}).results == ()


@pytest.mark.parametrize("sweep, expected", [
    ({"base": {"scene": "paper_fold"}, "vary": {"model.params.kk": [1.0, 2.0]},
      "compute": {"ik": {"targets": [[1.0, 0.5]]}}, "results": ["reachable"]}, "unknown parameter 'kk'"),
    ({"base": {"structure": "spine_c"}, "vary": {"members[side*].rest_lenght": {"uniform": {"low": 0.02, "high": 0.04}}},
      "samples": 2, "compute": "form_find", "results": ["stable"]},
     "unknown key 'rest_lenght' (did you mean 'rest_length'?)"),
])
def test_a_misspelt_last_key_is_refused_before_anything_runs(sweep, expected):
    """The last key of a key path may be new in the base (a parameter left at its default),
    but one that the computation's loader refuses at every probed value is a typo: the sweep
    is refused, where it would have run every point as an invalid row."""
    with pytest.raises(SweepError, match="takes none of its values there") as info:
        load_sweep(sweep)
    assert expected in str(info.value)


def test_a_new_key_that_some_values_suit_is_varied():
    """``model.params.k1`` is not in paper_fold's file (it defaults): accepted, and so is a
    quantity whose first value the loader refuses (that point becomes an invalid row)."""
    sweep = load_sweep({"base": {"scene": "paper_fold"}, "vary": {"model.params.k1": [-1.0, 1.0, 2.0]},
                        "compute": "simulate", "results": ["t_end"]})
    assert sweep.n_points == 3


def test_a_duplicate_key_is_refused_with_both_lines():
    text = GOOD.replace("compute: simulate", "compute: simulate\ncompute: form_find")
    err = error_of(text)
    assert "duplicate key 'compute'" in str(err)
    assert err.line == line_of(text, 'form_find') and f"(line {err.line})" in str(err)
    assert f"first at line {line_of(text, 'compute: simulate')}" in str(err)


def test_the_file_name_heads_the_message(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(GOOD.replace("name: t", "nme: t"))
    err = error_of(str(path))
    assert str(err).startswith("mine.yaml: nme: unknown key 'nme' (did you mean 'name'?)") and err.line == 1


def test_scaling_needs_a_number_in_the_base():
    err = error_of(GOOD.replace("model.params.c: {values: [0.0, 0.01]}", "model.params.ka: {values: [1.1], scale: true}"))
    assert "has no key 'ka'" in str(err)
    # without scale a new parameter is fine: the scene loader checks it at each point
    assert load_sweep(GOOD.replace("model.params.c", "model.params.ka")).quantities[1].locations == (("model", "params", "ka"),)


def test_ik_needs_a_class2_scene_and_targets():
    base = {"base": {"scene": "spine_release"}, "vary": {"duration": [1.0]}, "results": ["reachable"]}
    with pytest.raises(SweepError, match="needs a class2 scene"):
        load_sweep({**base, "compute": {"ik": {"targets": [[1.0, 0.5]]}}})
    with pytest.raises(SweepError, match="missing required key 'targets'"):
        load_sweep({**base, "base": {"scene": "paper_fold"}, "compute": "ik"})
    with pytest.raises(SweepError, match=r"item \[1\] must be a pair"):
        load_sweep({**base, "base": {"scene": "paper_fold"}, "compute": {"ik": {"targets": [[1, 0], [2]]}}})


def test_two_quantities_on_one_location_and_taken_column_names_are_refused():
    with pytest.raises(SweepError, match="already varied by 'members\\[side\\*\\].rest_length'"):
        load_sweep({"base": {"structure": "spine_c"}, "compute": "form_find", "results": ["stable"],
                    "vary": {"members[side*].rest_length": [0.03], "members[sidexp_0].rest_length": [0.04]}})
    with pytest.raises(SweepError, match="column name 'seed' is taken"):
        load_sweep(fold_sweep(vary={"inputs.f1.gain": {"values": [1.0], "name": "seed"}}))


def test_key_paths_select_groups_and_effects():
    doc = {"members": [{"name": "side_0", "l0": 1.0}, {"name": "diag_0", "l0": 2.0}, {"name": "side_1", "l0": 3.0}],
           "effects": ["inertia", {"damping": {"beta": 1e-3}}, "gravity"]}
    assert resolve(doc, "members[side*].l0") == [("members", 0, "l0"), ("members", 2, "l0")]
    assert resolve(doc, "effects[damping].beta") == [("effects", 1, "damping", "beta")]
    assert resolve(doc, "effects[gravity].vector") == [("effects", 2, "gravity", "vector")]
    assert doc["effects"][2] == {"gravity": {}}       # the same effect, now with (empty) options
    assert parse_pattern("loads.c1[2]") == (("key", "loads"), ("key", "c1"), ("index", 2))
    with pytest.raises(KeyPathError, match=r"no entry of members matches \[sied\*\] \(did you mean 'side\*'\?\)"):
        resolve(doc, "members[sied*].l0")
    with pytest.raises(KeyPathError, match="say which key"):
        resolve(doc, "members[side*]")
    with pytest.raises(KeyPathError, match=r"has 3 item\(s\), so no item \[3\]"):
        resolve(doc, "members[3].l0")


def test_scaled_values_multiply_every_selected_entry_and_leave_the_base_alone():
    sweep = load_sweep({"base": {"structure": "spine_c"}, "compute": "form_find", "results": ["stable"],
                        "vary": {"members[side*].rest_length": {"values": [0.5], "scale": True}}})
    base = sweep.base.document
    (q,) = sweep.quantities
    assert len(q.locations) == 36               # 4 side strings between each of the 10 vertebrae
    doc = apply(base, sweep.quantities, (0.5,))
    for loc in q.locations:
        member = doc["members"][loc[1]]
        assert member["name"].startswith("side")
        assert member["rest_length"] == 0.5 * base["members"][loc[1]]["rest_length"]
    untouched = [m for m in doc["members"] if not m["name"].startswith("side")]
    assert untouched == [m for m in base["members"] if not m["name"].startswith("side")]
    assert base["members"][0]["rest_length"] == 0.03          # the base is not changed


def test_grid_points_are_the_product_with_the_first_quantity_slowest():
    sweep = load_sweep(GOOD)
    assert sweep.n_points == 8
    values = [p.values for p in sweep.points()]
    assert values == [(k, c) for k in (0.5, 1.0, 1.5, 2.0) for c in (0.0, 0.01)]
    assert [p.index for p in sweep.points()] == list(range(8))


def test_random_points_depend_on_the_seed_and_their_index_only():
    a = load_sweep(monte_carlo_sweep(samples=20)).points()
    b = load_sweep(monte_carlo_sweep(samples=10)).points()
    assert [p.values for p in a[:10]] == [p.values for p in b]          # more samples extend the set
    assert [p.seed for p in a[:10]] == [p.seed for p in b]
    other = load_sweep({**monte_carlo_sweep(samples=10), "seed": 8}).points()
    assert all(p.values != q.values for p, q in zip(b, other))
    assert len({p.seed for p in a}) == len(a)


def test_normal_factors_have_the_mean_and_spread_asked_for():
    sweep = load_sweep(monte_carlo_sweep(samples=4000))
    k = np.array([p.values[0] for p in sweep.points()])
    m = np.array([p.values[1] for p in sweep.points()])
    # 4000 draws: the sample mean is within 4 standard errors of the true one
    assert abs(k.mean() - 1.0) < 4 * 0.05 / math.sqrt(4000)
    assert abs(k.std() - 0.05) < 4 * 0.05 / math.sqrt(2 * 4000)
    assert m.min() >= 1.8 and m.max() <= 2.2 and abs(m.mean() - 2.0) < 4 * (0.4 / math.sqrt(12)) / math.sqrt(4000)


def test_the_scene_gets_each_points_seed_unless_the_seed_is_varied():
    assert load_sweep(fold_sweep()).sets_seed
    assert not load_sweep(fold_sweep(vary={"seed": {"values": [1, 2], "name": "scene_seed"}})).sets_seed


def test_every_shipped_sweep_loads():
    assert set(sweep_names()) == {"fold_time_kc", "fold_monte_carlo", "spine_stability", "three_bar_crawl"}
    for name in sweep_names():
        sweep = load_sweep(name)
        assert sweep.n_points >= (12 if name == "three_bar_crawl" else 50) and sweep.description


def test_the_example_in_the_docs_is_a_valid_sweep():
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "sweeps.md").read_text()
    block = text.split("## A sweep file", 1)[1].split("```yaml\n", 1)[1].split("```", 1)[0]
    sweep = load_sweep(block)
    assert sweep.name == "fold_time_kc" and sweep.n_points == 17 * 8
    assert [p.values for p in sweep.points()] == [p.values for p in load_sweep("fold_time_kc").points()]


@pytest.mark.parametrize("base, vary, expected", [
    ({"scene": "paper_fold"}, {"model.params.k": ["a", "b"]},
     "vary.model.params.k: the base scene 'paper_fold' takes none of these values at 'model.params.k': "
     "model.params.k: must be a number, got a string ('a')"),
    ({"scene": "paper_fold"}, {"duration": [True, False]}, "takes none of these values at 'duration'"),
    ({"structure": "spine_c"}, {"members[side*].rest_length": ["short", "long"]},
     "takes none of these values at 'members[0].rest_length'"),
])
def test_values_all_of_the_wrong_kind_at_an_existing_key_are_refused_before_anything_runs(base, vary, expected):
    """Every point would be a failed row: refused as the sweep is read, with the loader's reason."""
    compute, result = ("simulate", "t_end") if "scene" in base else ("form_find", "stable")
    with pytest.raises(SweepError) as info:
        load_sweep({"base": base, "vary": vary, "compute": compute, "results": [result]})
    assert expected in str(info.value) and "\n" not in str(info.value)


def test_an_existing_key_with_some_values_of_its_kind_is_varied():
    """One number among words: the words' points become failed rows, the number's runs."""
    sweep = load_sweep({"base": {"scene": "paper_fold"}, "vary": {"model.params.k": ["a", 1.0, True]},
                        "compute": "simulate", "results": ["t_end"]})
    assert sweep.n_points == 3
