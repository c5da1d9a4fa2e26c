"""What a run reports about itself: the stiffness estimate before it, broken invariants after it.

Oracles: the stability polynomials of the explicit methods written out here (RK23's
propagated solution is third order with three stages, so ``R(z)`` is the Taylor polynomial
of ``e^z``; RK45's has the extra ``z^6/600``), step counts of scipy's own ``solve_ivp`` on
``y' = -sigma y``, and trajectories broken on purpose.
"""

from __future__ import annotations

import copy
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import Polynomial
from scipy.integrate import solve_ivp

from tensegrity_core.sim import compile_scene, load_scene, simulate, stiffness_check
from tensegrity_core.sim.invariants import violations
from tensegrity_core.sim.scene import scene_from_text
from tensegrity_core.sim.stiffness_check import StiffnessWarning, check_integrator, real_stability_limit, warn_if_stiff
from tensegrity_ros.cli import main

DOCS = Path(__file__).resolve().parents[2] / "docs" / "scenes.md"


def complete_scene_text() -> str:
    """The YAML of docs/scenes.md's "A complete scene", as a user copies it."""
    text = DOCS.read_text()
    block = text[text.index("## A complete scene"):]
    block = block[block.index("```yaml\n") + len("```yaml\n"):]
    return block[:block.index("```\n")]


def first_real_root_above_zero(poly: Polynomial) -> float:
    """The smallest x > 0 with |R(-x)| = 1 (R(-x) = -1 or +1), R a stability polynomial."""
    roots = np.concatenate([(poly + 1).roots(), (poly - 1).roots()])
    return min(-r.real for r in roots if abs(r.imag) < 1e-9 and r.real < -1e-9)


@pytest.mark.parametrize("method, coefficients", [
    ("RK23", [1, 1, 1 / 2, 1 / 6]),
    ("RK45", [1, 1, 1 / 2, 1 / 6, 1 / 24, 1 / 120, 1 / 600]),
])
def test_the_stability_limits_are_those_of_the_methods_stability_polynomials(method, coefficients):
    assert real_stability_limit(method) == pytest.approx(first_real_root_above_zero(Polynomial(coefficients)),
                                                         rel=1e-6)


@pytest.mark.parametrize("method", ["RK23", "RK45", "DOP853"])
def test_a_decaying_mode_forces_the_steps_the_estimate_says(method):
    """On y' = -sigma y with a loose tolerance the step size is set by stability alone: scipy's
    own solver takes about duration sigma / r steps."""
    sigma, duration = 1e5, 0.05
    sol = solve_ivp(lambda t, y: -sigma * y, (0.0, duration), [1.0], method=method, rtol=1e-2, atol=1e-2)
    fit = check_integrator(method, np.array([[-sigma]]), duration)
    assert fit.decay_rate == pytest.approx(sigma)
    assert sol.t.size - 1 == pytest.approx(fit.explicit_steps, rel=0.25)


def test_the_docs_complete_scene_with_an_explicit_method_is_said_to_be_stiff_before_running():
    """Its compliant drive decays at k_a/c_d = 1e7 1/s: DOP853 would need ~7.8e6 steps for 5 s."""
    scene = scene_from_text(complete_scene_text().replace("method: auto", "method: DOP853"))
    model = compile_scene(scene)
    with pytest.warns(StiffnessWarning, match="Radau, BDF or LSODA") as caught:
        fit = warn_if_stiff(model, model.initial_state(), scene.duration)
    assert fit.decay_rate == pytest.approx(1e6 / 0.1, rel=1e-6)
    assert fit.explicit_steps == pytest.approx(5.0 * 1e7 / real_stability_limit("DOP853"), rel=1e-6)
    assert "7.8e+06 steps" in str(caught[0].message)


def test_the_docs_complete_scene_runs_as_written_and_fits_its_method():
    """The whole 5 s: rho1 is held from 4.96 s on, where Radau's linear algebra leaves its
    length at +-3e-33 m, which is on the stop (``tensegrity simulate`` exited 1 on it)."""
    scene = scene_from_text(complete_scene_text())
    model = compile_scene(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("error", StiffnessWarning)
        assert warn_if_stiff(model, model.initial_state(), scene.duration).fits
        traj = simulate(scene)
    assert traj.success and traj.stats["method"] == "Radau" and traj.violations == []


@pytest.mark.parametrize("name", ["paper_fold", "class2_at_rest", "table_gravity", "stiff_fold"])
def test_shipped_scenes_fit_their_methods(name):
    scene = load_scene(name)
    model = compile_scene(scene)
    assert warn_if_stiff(model, model.initial_state(), scene.duration).fits


def test_the_cli_says_so_before_the_run(tmp_path, capsys, monkeypatch):
    """A short run (so a lowered threshold): one ``warning:`` line naming the implicit methods."""
    monkeypatch.setattr(stiffness_check, "MAX_EXPLICIT_STEPS", 100)
    path = tmp_path / "stiff.yaml"
    path.write_text(complete_scene_text().replace("method: auto", "method: DOP853"))
    assert main(["simulate", str(path), "--duration", "1e-4", "--quiet"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("warning: integrator.method DOP853 is explicit and this scene is stiff")


# -- invariants -----------------------------------------------------------------------------------
def fold_data():
    scene = load_scene("paper_fold").with_duration(3.5)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    samples = []
    model.record(state, np.linspace(0.0, scene.duration, 351), samples)
    return model.observe(samples), list(state.events)


def test_a_sound_run_breaks_no_invariant():
    data, events = fold_data()
    assert violations(data, events, fold_limit=True) == []
    assert simulate("paper_fold").violations == []


def test_a_leak_through_the_fold_limit_and_a_pulling_stop_are_named():
    data, events = fold_data()
    broken = copy.deepcopy(data)
    broken["q"][200:, 0] -= 0.05                       # rho1 through its stop
    held = np.flatnonzero(broken["contact_forces"][:, 1] > 0)[0]
    broken["contact_forces"][held, 1] = -3.0           # rho2's stop pulls
    found = violations(broken, events, fold_limit=True)
    assert any(line.startswith("actuator length rho1 = ") and "below zero at t = " in line for line in found)
    assert any(line.startswith("the stop of rho2 pulls: contact force -3 N") for line in found)
    assert violations(broken, events, fold_limit=False) == []       # without the limit, lengths are free
    held = np.flatnonzero(data["contact_forces"][:, 0] > 0)
    for shift, named in ((1e-33, False), (1e-3, True)):            # rounding, and a real gap [m]
        moved = copy.deepcopy(data)
        moved["q"][held[-1], 0] = shift
        found = violations(moved, events, fold_limit=True)
        assert any(line.endswith(f"m, off its stop, at t = {data['t'][held[-1]]:.9g} s") for line in found) == named


def test_events_out_of_order_or_contradicting_are_named():
    data, _ = fold_data()
    found = violations(data, [(1.0, "fold", 0), (0.5, "fold", 1), (0.5, "release", 1), (0.5, "fold", 1)],
                       fold_limit=True)
    assert any("out of time order" in line for line in found)
    assert any("release 1 and fold 1 at one instant" in line for line in found)
    assert any("fold 1 twice" in line for line in found)


def test_the_cli_reports_a_violation_and_exits_1(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("tensegrity_core.sim.simulator.violations",
                        lambda data, events, fold_limit: ["actuator length rho1 = -0.06 m below zero at t = 5 s"])
    out = tmp_path / "run.npz"
    assert main(["simulate", "paper_fold", "--duration", "0.1", "--quiet", "-o", str(out)]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err == ["error: invariant violated: actuator length rho1 = -0.06 m below zero at t = 5 s"]
    from tensegrity_core.sim import Trajectory
    assert Trajectory.from_npz(out).violations == ["actuator length rho1 = -0.06 m below zero at t = 5 s"]


def test_a_sweep_point_that_breaks_an_invariant_has_the_status_violated(monkeypatch):
    from tensegrity_core.sweep import load_sweep
    from tensegrity_core.sweep.points import build_points
    from tensegrity_core.sweep.spec import prepare
    from tensegrity_core.sweep.task import run_point
    from tests.sweep.conftest import fold_sweep

    sweep = load_sweep(fold_sweep(vary={"inputs.f1.gain": [10.0]}, compute={"simulate": {"duration": 0.2}}))
    plan = prepare(sweep)
    point = build_points(sweep.quantities, sweep.samples, sweep.seed)[0]
    assert run_point(plan, point)["status"] == "ok"
    monkeypatch.setattr("tensegrity_core.sim.simulator.violations",
                        lambda data, events, fold_limit: ["the stop of rho2 pulls: contact force -3 N"])
    row = run_point(plan, point)
    assert row["status"] == "violated" and row["message"] == "the stop of rho2 pulls: contact force -3 N"
    assert json.dumps(row, default=str)
