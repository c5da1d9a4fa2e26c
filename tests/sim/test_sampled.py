"""The core's sampled-data runs (issue 14): a controller sampled every period and held,
times from integers, the CLI (`tensegrity simulate --control-period --controller`)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tensegrity_core.class2.fold_law import paper_fold_forces
from tensegrity_core.sim import SimulationError, simulate
from tensegrity_core.sim.sampled import run_sampled, step_ns_of, step_time, steps_in
from tensegrity_ros.cli import main

MODEL = {"kind": "class2", "params": {"L": 1.0, "k": 1.0, "c": 0.01, "m": 2.0}}
EFFECTS = ["inertia", "springs", "damping", "fold_limit"]


def test_step_times_come_from_integers_not_from_an_accumulated_float():
    # 3 * 1e8 ns / 1e9 is the double nearest 0.3; adding 0.1 three times is not
    assert step_time(3, 100_000_000) == 0.3 and 0.1 + 0.1 + 0.1 != 0.3
    h = step_ns_of(0.001)
    assert h == 1_000_000
    assert [step_time(k, h) for k in (0, 1000, 4000)] == [0.0, 1.0, 4.0]
    assert steps_in(4.0, h) == 4000 and steps_in(4.0005, h) == 4001
    for bad in (0.0, -1.0, float("nan"), True):
        with pytest.raises(SimulationError):
            step_ns_of(bad)


def test_a_constant_controller_reproduces_the_run_with_constant_inputs():
    """Held constant forces are constant forces: the sampled run must follow the continuous
    run of the scene whose inputs are those constants (to the integrators' accuracy)."""
    forces = (0.6, -0.1)
    commanded = {"model": MODEL, "initial": {"equilibrium": {"rho1": 0.7, "rho2": 0.7}},
                 "inputs": {"f1": {"law": "commanded"}, "f2": {"law": "commanded"}}, "effects": EFFECTS,
                 "output": {"rate": 100}, "duration": 2.0,
                 "integrator": {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12}}
    constant = dict(commanded, inputs={"f1": forces[0], "f2": forces[1]})
    run = run_sampled(commanded, lambda s: forces, step_size=0.01)
    ref = simulate(constant)
    assert run.success and len(run.times) == 201
    np.testing.assert_allclose(run.q, ref.q[:len(run.times)], atol=1e-8)
    assert np.all(run.commands == np.array(forces))


def test_the_sampled_fold_converges_to_the_continuous_fold_at_first_order():
    """A zero-order hold delays the force law by half a period on average, so the first
    fold time moves by O(h): ten times the rate, about a tenth of the shift."""
    cont = simulate("paper_fold", duration=2.0)
    t_cont = next(t for t, k, i in cont.events if k == "fold" and i == 1)
    shifts = []
    for hz in (100, 1000):
        run = run_sampled("class2_at_rest", paper_fold_forces, step_size=1.0 / hz, duration=2.0)
        shifts.append(next(t for t, k, i in run.events if k == "fold" and i == 1) - t_cont)
    assert 5 < shifts[0] / shifts[1] < 20
    assert abs(shifts[1]) < 2e-3


def test_a_failing_controller_names_the_step():
    def broken(sample):
        if sample.t > 0.05:
            raise ValueError("no more")
        return (0.0, 0.0)

    with pytest.raises(SimulationError, match=r"controller failed at t = 0.06 s \(step 6\): ValueError: no more"):
        run_sampled("class2_at_rest", broken, step_size=0.01, duration=1.0)
    with pytest.raises(SimulationError, match=r"step 0\) is not a command: command must have 2 values"):
        run_sampled("class2_at_rest", lambda s: (1.0, 2.0, 3.0), step_size=0.01, duration=1.0)


def test_cli_sampled_run_matches_the_api(capsys, tmp_path):
    out = tmp_path / "run.npz"
    rc = main(["simulate", "class2_at_rest", "--control-period", "0.01", "--controller",
               "tensegrity_core.class2.fold_law:paper_fold_forces", "--duration", "2", "--json", "-o", str(out)])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    run = run_sampled("class2_at_rest", paper_fold_forces, step_size=0.01, duration=2.0)
    assert summary["steps"] == 200 and summary["control_period_ns"] == 10_000_000
    assert [(e["t"], e["kind"], e["subject"]) for e in summary["events"]] == \
        [(t, k, f"rho{i + 1}") for t, k, i in run.events]          # the paper's fold: folds of rho1, rho2
    data = np.load(out)
    np.testing.assert_array_equal(data["q"], run.q)


@pytest.mark.parametrize("argv, message", [
    (["--controller", "nowhere_module:f", "--control-period", "0.01"], "cannot import 'nowhere_module'"),
    (["--controller", "math", "--control-period", "0.01"], "expects MODULE:FUNCTION"),
    (["--controller", "math:nothing_here", "--control-period", "0.01"], "has no function 'nothing_here'"),
    (["--controller", "math:cos"], "go together"),
    (["--controller", "math:cos", "--control-period", "-1"], "must be in (0, 3600)"),
])
def test_cli_sampled_run_errors_are_one_line(argv, message, capsys):
    assert main(["simulate", "class2_at_rest", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


@pytest.mark.parametrize("sampled", [
    [],
    ["--control-period", "0.01", "--controller", "tensegrity_core.class2.fold_law:paper_fold_forces"],
])
def test_an_output_that_cannot_be_written_is_one_error_line(sampled, tmp_path, capsys):
    out = tmp_path / "no_such_folder" / "run.npz"
    assert main(["simulate", "class2_at_rest", "--duration", "0.05", "--quiet", "-o", str(out), *sampled]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: cannot write {str(out)!r}: No such file or directory")
