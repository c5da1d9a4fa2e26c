"""Grazes of the fold limit inside one integrator step, and the stepper's progress guarantee.

A free actuator that comes down to its stop and turns back inside one step has both step
ends above the stop; whether it dipped through is decided on the step's own dense output,
and any dip deeper than the position tolerance ``atol`` is located, so an actuator's length
stays above ``-(atol + PENETRATION_REL L)`` (``test_invariants.length_tolerance``).
"""

from __future__ import annotations

import copy

import numpy as np

from tensegrity_core.sim import compile_scene, load_scene

from .test_invariants import assert_events_consistent, assert_fold_limit_holds, fold_scene, record


def test_a_near_tangent_graze_inside_one_step_folds_the_actuator():
    """A point of the issue's box (k 7.0 N/m, c 0.42 N s/m, gain 48.5, restitution 0.78) under
    DOP853 at rtol 1e-7, atol 1e-9: rho2 comes down to the stop and turns back inside one step
    (4.122 s to 4.159 s) whose ends are both above it, and the cubic through the step's end
    values and rates stays above it too, while the integrated motion goes 6e-8 m below. The
    dip is found on the dense output: a fold of rho2 in that step, and every sample (5 kHz)
    at or above ``-(atol + PENETRATION_REL L)``."""
    scene = fold_scene(k=6.999123489755537, c=0.4222766831143423, gain=48.51130033010531,
                       restitution=0.777417297704791, method="DOP853", rtol=1e-7, atol=1e-9)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    data, err = record(model, state, np.linspace(0.0, scene.duration, 25001))
    assert err is None
    assert_fold_limit_holds(data, state.events, scene)
    assert any(kind == "fold" and index == 1 and 4.12 < t < 4.16 for t, kind, index in state.events)


class BoundedLog(list):
    """An event log that refuses more than ``limit`` entries: a run that restarts without end
    fails here instead of hanging."""

    limit = 200

    def extend(self, entries):
        super().extend(entries)
        assert len(self) <= self.limit, f"over {self.limit} events, the last {self[-3:]}"


def test_a_run_whose_interpolant_wiggles_through_the_stop_makes_progress():
    """The paper's fold under Radau at rtol 1e-3 with an absolute tolerance of 1e-14 m: just
    after rho2 lifts off the stop (t = 1.38 s) the collocation polynomial of the long first step
    dips below the stop by more than that tolerance. The dip is located once and handled as a
    bounce at rest speed that leaves rho2 free, as it was; the stepper then looks for no more
    grazes of rho2 in that step, so the run goes on (without that, it logged a fold every 2 ns,
    thousands without end) and ends with the paper's events in order."""
    d = copy.deepcopy(load_scene("paper_fold").data)
    d["integrator"] = {"method": "Radau", "rtol": 1e-3, "atol": 1e-14}
    scene = load_scene(d)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    log = BoundedLog()
    state.work.event_log = log
    model.record(state, np.linspace(0.0, scene.duration, 101), [])
    assert state.work.t == scene.duration
    assert_events_consistent(log)
    assert {(kind, index) for _, kind, index in log} == {("fold", 0), ("fold", 1), ("release", 0)}
