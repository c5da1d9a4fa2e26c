"""The set-up's warm-up compiles every kernel signature a run needs (kernels/warm.py).

numba compiles a kernel once per kind of its arguments (dtype, dimensions, memory layout,
writable or not); ``./run setup`` compiles each kernel once into the on-disk cache
(``python -m tensegrity_core.sim.general.kernels.warm``). A call with another kind of array --
a plan whose member ends are a column of a read-only table, a plan built by hand -- compiles
the kernel again, in a test worker or in a user's first run: seconds to minutes on a busy
machine. Here a representative set of runs -- each integrator path (DOP853 and RK4 stretches,
single steps under a moving rest length, Radau's Jacobian), with and without rigid bodies,
dampers, loads and gravity, strings going slack and taut, batch observation, plans built by
hand, a robot -- may add no signature to those of the warm-up.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tensegrity_core.general import prism_tower
from tensegrity_core.general.writing import structure_to_dict
from tensegrity_core.sim import compile_scene, load_scene, simulate
from tensegrity_core.sim.general.kernels.jit import have_numba

from .test_general import BODIES, general_scene

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not have_numba(), reason="the compiled kernels need numba (the 'fast' extra)")


def _signatures() -> dict[str, list[str]]:
    """Per compiled kernel of the general and the robot back ends, its signatures in this process."""
    from tensegrity_core.sim.general.kernels import loops
    from tensegrity_core.sim.general.robot import loops as robot_loops
    from tensegrity_core.sim.general.robot import step_loops

    return {f"{module.__name__}.{name}": [str(s) for s in kernel.signatures]
            for module in (loops, robot_loops, step_loops) for name, kernel in vars(module).items()
            if hasattr(kernel, "signatures") and getattr(kernel, "py_func", None) is not None
            and kernel.py_func.__module__ == module.__name__}


def _tower(**extra):
    """A two-stage 3-prism tower shaken hard (its strings go slack and taut), damped, loaded
    and under gravity."""
    s = prism_tower(2, sides=3, EA=2e3)
    structure = structure_to_dict(s.replace(node_masses=np.full(s.n_nodes, 0.1)))
    effects = ["inertia", "springs", {"damping": {"c": 0.2}}, {"gravity": {"vector": [0.0, 0.0, -9.81]}},
               {"loads": {s.node_names[-1]: [3.0, 0.0, 0.0]}}]
    return structure, effects


def _shaken(scene, seed: int = 5):
    model = compile_scene(scene)
    y0 = model.initial_state().y.copy()
    half = len(y0) // 2
    y0[half:] = np.random.default_rng(seed).normal(0.0, 3.0, half)
    return model, model.state_from(y0, t_end=scene.duration)


def _by_hand(plan, y):
    """Plans built by hand from another's arrays -- writable copies of them all; their member
    ends a column each of a read-only table -- and their right-hand sides, Jacobians and steps."""
    from tensegrity_core.sim.general.kernels.evaluator import Evaluator
    from tensegrity_core.sim.general.kernels.plan import Plan
    from tensegrity_core.sim.general.kernels.stages import CompiledStages

    copies = Plan(*(np.array(a) for a in plan))
    table = np.stack([plan.member_a, plan.member_b], axis=1)
    table.setflags(write=False)
    nb = len(plan.body_dof)
    R_ref = np.tile(np.eye(3), (nb, 1, 1))
    l0 = np.linalg.norm(plan.base[plan.member_b] - plan.base[plan.member_a], axis=1)
    screen = {"strings": np.flatnonzero(plan.is_string), "moving": np.zeros(int(plan.is_string.sum()), dtype=bool),
              "rechart_angle": 1.0}
    for by_hand in (copies, copies._replace(member_a=table[:, 0], member_b=table[:, 1])):
        evaluator = Evaluator(by_hand, "numba")
        f = evaluator.derivative(y, R_ref, l0)
        evaluator.jacobian(y, R_ref, l0)
        evaluator.evaluate(np.tile(y, (2, 1)), np.tile(R_ref, (2, 1, 1, 1)), np.tile(l0, (2, 1)))
        stages = CompiledStages(by_hand, R_ref, lambda t: l0, True, **screen)
        stages.rk4(0.0, y, f, 1e-4)
        stages.dop853(0.0, y, f, 1e-4, 1e-6, 1e-8)


def _runs():
    structure, effects = _tower()
    for integrator in ({"method": "DOP853", "rtol": 1e-7, "atol": 1e-9}, {"method": "RK4", "max_step": 5e-4},
                       {"method": "Radau", "rtol": 1e-6, "atol": 1e-8}):
        model, state = _shaken(general_scene(structure, effects, duration=0.05, integrator=integrator))
        model.record(state, np.linspace(0.0, 0.05, 11), [])
        assert state.events                        # strings went slack or taut
    cable = next(m for m in structure["members"] if m.get("type", "string") == "string")
    cable.update(type="actuator", name="act")
    simulate(general_scene(structure, effects, duration=0.02, integrator={"method": "RK4", "max_step": 5e-4},
                           inputs={"act": {"law": "ramp", "from": cable["rest_length"],
                                           "to": 0.9 * cable["rest_length"], "t1": 0.02}}))
    bodies = general_scene(BODIES, ["inertia", "springs", {"damping": {"c": 0.4}}], duration=0.02)
    simulate(bodies)
    model = compile_scene(bodies)
    state = model.initial_state()
    system = model.equations(state).resume(state.t, state.y).system
    system.jac(0.0, state.y)
    system.string_gaps(0.0, state.y)
    _by_hand(system.plan, state.y)
    for name in ("table_gravity", "spine_release"):
        simulate(load_scene(name).with_duration(0.01))
    robot = load_scene({"model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
                        "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"],
                        "duration": 0.01})
    simulate(robot)


def added_signatures() -> dict[str, list[str]]:
    """Warm the kernels up as the set-up does, make the runs, and return the signatures the
    runs added, per kernel (empty: the warm-up compiled everything they needed)."""
    from tensegrity_core.sim.general.kernels.warm import warm

    warm()
    warmed = _signatures()
    _runs()
    return {k: sorted(set(v) - set(warmed[k])) for k, v in _signatures().items() if set(v) - set(warmed[k])}


def test_the_runs_add_no_signature_to_the_warm_ups():
    """In a fresh process (this one's kernels may have met other tests' calls): warm-up, then
    the runs."""
    script = "import json; from tests.sim.test_kernel_signatures import added_signatures; " \
             "print(json.dumps(added_signatures()))"
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    assert json.loads(done.stdout.splitlines()[-1]) == {}
