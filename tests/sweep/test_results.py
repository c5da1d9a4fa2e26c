"""What each computation keeps, checked against derivations, the paper's stated results and
the core's own public functions called directly; failures as rows. These run the points in
this process (``workers=0``): the engine is the subject of test_engine.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensegrity_core.class2 import PAPER_PARAMS, inverse_kinematics
from tensegrity_core.sim import load_scene, simulate
from tensegrity_core.sweep import SweepError, load_sweep, run_sweep
from tests.sweep.conftest import fold_sweep

EA, L0 = 1000.0, 1.0
HANGING = {"name": "hanging", "nodes": {"top": [0.0, 0.0, 0.0], "m": [0.0, 0.0, -1.0]},
           "members": [{"name": "s", "nodes": ["top", "m"], "EA": EA, "rest_length": L0}],
           "pinned": {"top": "xyz"}, "loads": {"m": [0.0, 0.0, -10.0]}}


def test_a_hanging_mass_sits_where_hookes_law_puts_it(tmp_path):
    """One string of stiffness EA and rest length l0 carrying F: the tension is F, the length
    l0 (1 + F/EA), and K_T's eigenvalues are EA/l0 (along the string) and F/l twice (the
    pendulum's geometric stiffness sideways), so the smallest is F/l."""
    import yaml

    (tmp_path / "hanging.yaml").write_text(yaml.safe_dump(HANGING))
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(yaml.safe_dump({
        "base": {"structure": "hanging.yaml"}, "compute": "stiffness",
        "vary": {"loads.m[2]": {"values": [-10.0, -100.0, -250.0], "name": "fz"},
                 "members[s].rest_length": {"values": [1.0, 1.2], "scale": True, "name": "l0_factor"}},
        "results": ["min_eigenvalue", {"eigenvalues": {"n": 3}}, "stable", {"node": {"name": "m"}},
                    "max_member_force", "rank"]}))
    table = run_sweep(str(sweep), workers=0, progress=False)
    assert list(table["status"]) == ["ok"] * 6
    for row in table.itertuples():
        F, l0 = -row.fz, L0 * row.l0_factor
        length = l0 * (1 + F / EA)
        assert row.m_z == pytest.approx(-length, rel=1e-9) and abs(row.m_x) < 1e-12
        assert row.max_member_force == pytest.approx(F, rel=1e-9)
        assert row.min_eigenvalue == pytest.approx(F / length, rel=1e-7)
        got = sorted([row.eigenvalue_1, row.eigenvalue_2, row.eigenvalue_3])
        assert got == pytest.approx(sorted([F / length, F / length, EA / l0]), rel=1e-7)
        assert row.stable and row.rank == 1


def test_the_papers_first_fold_and_direct_runs_agree_with_the_sweep():
    table = run_sweep(fold_sweep(), workers=0, progress=False)
    assert list(table["inputs.f1.gain"]) == [8.0, 10.0, 12.0]
    paper = table[table["inputs.f1.gain"] == 10.0].iloc[0]
    assert paper.first_fold_time == pytest.approx(1.381, abs=5e-4)     # docs/scenes.md: rho2 folds at 1.381 s
    scene = load_scene("paper_fold").data
    for row in table.itertuples():
        doc = {**scene, "inputs": {**scene["inputs"], "f1": {"law": "proportional", "gain": row[2]}},
               "seed": int(row.seed)}
        traj = simulate(load_scene(doc), duration=1.6)
        folds = [t for t, kind, _ in traj.events if kind == "fold"]
        assert row.first_fold_time == (min(folds) if folds else math.nan)
        assert row.t_end == 1.6
        assert [row.final_rho1, row.final_rho2, row.final_beta] == list(traj.q[-1])


def test_actuators_count_from_1_as_their_names_do():
    """``actuator: 2`` is rho2 (the paper's fold: rho2 folds at 1.381 s, docs/scenes.md), its
    column ``first_fold_time_2``; 0 is refused with the convention in the message."""
    table = run_sweep(fold_sweep(vary={"inputs.f1.gain": [10.0]},
                                 results=[{"first_event_time": {"kind": "fold", "actuator": 2}},
                                          {"event_count": {"kind": "fold", "actuator": 1}}]),
                      workers=0, progress=False)
    assert table["first_fold_time_2"][0] == pytest.approx(1.381, abs=5e-4)
    traj = simulate("paper_fold", duration=1.6)
    assert table["first_fold_time_2"][0] == min(t for t, kind, i in traj.events if kind == "fold" and i == 1)
    assert table["fold_count_1"][0] == sum(1 for _, kind, i in traj.events if kind == "fold" and i == 0)
    with pytest.raises(SweepError, match=r"must be >= 1 \(an actuator \(counted from 1: 1 = rho1, 2 = rho2\)\), got 0"):
        load_sweep(fold_sweep(results=[{"first_event_time": {"kind": "fold", "actuator": 0}}]))


def test_bad_values_are_invalid_rows_with_the_loaders_message():
    table = run_sweep(fold_sweep(vary={"model.params.k": [1.0, -1.0, "stiff"]}), workers=0, progress=False)
    assert list(table["status"]) == ["ok", "invalid", "invalid"]
    assert "model.params.k: must be > 0 N/m, got -1.0 N/m" in table["message"][1]
    assert "must be a number" in table["message"][2] and "model.params.k" in table["message"][2]
    assert math.isnan(table["first_fold_time"][1]) and table["point"].tolist() == [0, 1, 2]


def test_a_structure_without_a_stable_equilibrium_is_a_failed_row_with_its_results():
    sweep = {"base": {"structure": "spine_c"}, "compute": "form_find",
             "vary": {"members[diag*].rest_length": {"values": [1.0, 1.1], "scale": True, "name": "diag"}},
             "results": ["stable", "slack_members", "min_eigenvalue"]}
    table = run_sweep(sweep, workers=0, progress=False)
    assert list(table["status"]) == ["ok", "failed"]
    assert bool(table["stable"][0]) and not bool(table["stable"][1])
    assert table["slack_members"][0] == 0 and table["slack_members"][1] > 0    # long diagonals go slack
    assert "unstiffened mechanism" in table["message"][1] or "unstable" in table["message"][1]


def test_ik_counts_the_targets_the_mechanism_reaches():
    targets = [[1.45, 0.70], [0.5, 1.2], [1.0, 0.3], [0.9, 0.45]]
    sweep = {"base": {"scene": "paper_fold"}, "compute": {"ik": {"targets": targets}},
             "vary": {"model.params.L": [1.0, 0.5]},
             "results": ["reachable", "reachable_fraction", "max_fk_residual", "min_singularity_distance"]}
    table = run_sweep(sweep, workers=0, progress=False)
    for row in table.itertuples():
        params = PAPER_PARAMS.with_overrides(L=row[2])
        solved = [inverse_kinematics(x, y, params).valid for x, y in targets]
        assert row.reachable == sum(1 for s in solved if s)
        assert row.reachable_fraction == row.reachable / 4
        # |y| > L is out of reach whatever the actuators do
        assert row.reachable <= sum(1 for _, y in targets if abs(y) <= row[2])
        if row.reachable:
            assert row.max_fk_residual < 1e-9 and row.min_singularity_distance > 0
        else:
            assert math.isnan(row.max_fk_residual) and math.isnan(row.min_singularity_distance)
    assert table["reachable"][0] > table["reachable"][1]


def test_the_base_run_is_its_own_reference():
    sweep = fold_sweep(vary={"inputs.f1.gain": [10.0, 11.0]},
                       results=["t_end", "error_vs_reference", {"error_vs_reference": {"of": "end_effector"}}],
                       compute="simulate")
    table = run_sweep(sweep, workers=0, progress=False)
    assert table["error_vs_reference"][0] == 0.0 and table["error_vs_reference_end_effector"][0] == 0.0
    assert table["error_vs_reference"][1] > 1e-3


def read_csv_exact(pd, path):
    return pd.read_csv(path, **({} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}))


def test_csv_and_parquet_hold_the_same_table(tmp_path):
    pd = pytest.importorskip("pandas")
    a = run_sweep(fold_sweep(), workers=0, progress=False, output=tmp_path / "r.parquet")
    b = run_sweep(fold_sweep(), workers=0, progress=False, output=tmp_path / "r.csv")
    for path in (tmp_path / "r.parquet", tmp_path / "r.csv"):
        back = pd.read_parquet(path) if path.suffix == ".parquet" else read_csv_exact(pd, path)
        for column in ("point", "inputs.f1.gain", "seed", "first_fold_time", "final_beta", "status"):
            assert list(back[column]) == list(a[column]), (path, column)
    assert not (tmp_path / "r.csv.partial.jsonl").exists() and not (tmp_path / "r.parquet.partial.jsonl").exists()
    drop = ["run_time"]
    pd.testing.assert_frame_equal(a.drop(columns=drop), b.drop(columns=drop))


def test_the_shipped_spine_sweep_computes_what_form_finding_does():
    """Two points of the shipped spine sweep equal form_find on the scaled structure."""
    from tensegrity_core.general import form_find, load_example

    sweep = load_sweep("spine_stability")
    points = [p for p in sweep.points() if p.values in ((1.0, 1.0), (0.6, 1.1))]
    from tensegrity_core.sweep.spec import prepare
    from tensegrity_core.sweep.task import run_point

    plan = prepare(sweep)
    base = load_example("spine_c")
    for p in points:
        row = run_point(plan, p)
        l0 = base.rest_lengths * np.where([n.startswith("side") for n in base.member_names], p.values[0], 1.0)
        l0 = l0 * np.where([n.startswith("diag") for n in base.member_names], p.values[1], 1.0)
        direct = form_find(base.with_rest_lengths(l0))
        assert row["stable"] == direct.stable and row["iterations"] == direct.iterations
        assert row["min_eigenvalue"] == pytest.approx(direct.min_eigenvalue, rel=1e-9, abs=1e-9)
    assert {p.values for p in points} == {(1.0, 1.0), (0.6, 1.1)}
