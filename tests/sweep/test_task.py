"""What a worker does with a batch: a point's ``run_time`` is the point's own.

A fresh worker process has not imported the core modules a computation runs on (the
simulator pulls in scipy: 0.5-0.7 s, against ~0.03 s for a point of the shipped examples).
They are imported before the first point's clock starts, not inside it. Checked by the order
of events in a fresh interpreter, not by a timing: each import of those modules and each
read of the task's clock is recorded as it happens.
"""

from __future__ import annotations

import json
import pickle
import subprocess
import sys
import textwrap

import pytest

from tensegrity_core.sweep import load_sweep
from tensegrity_core.sweep.computations import COMPUTATIONS
from tensegrity_core.sweep.points import build_points
from tensegrity_core.sweep.spec import prepare
from tests.sweep.conftest import fold_sweep

CHILD = textwrap.dedent("""\
    import json, pickle, sys, time

    events = []
    watched = set(sys.argv[2:])

    class Watch:                       # notes an import of a watched module as it starts
        def find_spec(self, name, path, target=None):
            if name in watched:
                events.append("import " + name)
            return None

    sys.meta_path.insert(0, Watch())
    from tensegrity_core.sweep import task

    class Clock:                       # the task's clock, each read noted
        def perf_counter(self):
            events.append("clock")
            return time.perf_counter()

    task.time = Clock()
    with open(sys.argv[1], "rb") as f:
        plan, points = pickle.load(f)
    fresh = not any(m in sys.modules for m in watched)
    rows = task.run_batch(plan, points)
    print(json.dumps({"fresh": fresh, "events": events, "status": [r["status"] for r in rows]}))
    """)

SWEEPS = {
    "simulate": fold_sweep(vary={"inputs.f1.gain": [9.0, 10.0]}, compute={"simulate": {"duration": 0.5}}),
    "form_find": {"base": {"structure": "spine_c"}, "vary": {"members[side*].rest_length": {"values": [1.0, 0.95],
                  "scale": True}}, "compute": "form_find", "results": ["residual"]},
    "ik": {"base": {"scene": "paper_fold"}, "vary": {"model.params.k": [1.0, 2.0]},
           "compute": {"ik": {"targets": [[1.0, 0.5]]}}, "results": ["reachable"]},
}


@pytest.mark.parametrize("computation", sorted(SWEEPS))
def test_a_fresh_worker_imports_the_computations_modules_before_it_times_a_point(computation, tmp_path):
    sweep = load_sweep(SWEEPS[computation])
    plan = prepare(sweep)
    points = build_points(sweep.quantities, sweep.samples, sweep.seed)
    with open(tmp_path / "batch.pkl", "wb") as f:
        pickle.dump((plan, points), f)
    modules = COMPUTATIONS[computation].modules
    out = subprocess.run([sys.executable, "-c", CHILD, str(tmp_path / "batch.pkl"), *modules],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-3000:]
    got = json.loads(out.stdout)
    assert got["fresh"], "the modules were imported before the batch: the check would prove nothing"
    assert got["status"] == ["ok", "ok"]
    events = got["events"]
    assert events.count("clock") == 2 * len(points)            # start and end of each point
    first_clock = events.index("clock")
    assert {f"import {m}" for m in modules} <= set(events[:first_clock]), events
