"""``python -m tensegrity_core.sim.general.kernels.warm``: compile every numba kernel into its
on-disk cache, once (``./run setup`` does it after installing numba or changing a kernel).

numba compiles a kernel the first time a process calls it and, with ``cache=True``, keeps
the machine code next to the sources, where every later process (test workers, the demo,
the ROS nodes) loads it in a fraction of a second. Compiling all of them (42 kernels, 45
signatures) takes about 40 s of CPU on one thread; in ``./run setup`` it shares the two cores
with the interface builds, the byte-compilation and mypy, so its wall time there is 2-3 times
that (the line it prints gives both). Doing it here keeps that cost out
of the first simulation a user runs and out of parallel test workers that would each
compile the same kernels at once.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from tensegrity_core.sim.general.kernels.jit import have_numba

#: A small structure with every kind of part: a free node, a partly pinned node, a rigid
#: body, strings, a bar, masses. The kernels compile once for all structures: every plan's
#: arrays are of one kind (:func:`~.plan.frozen`), the states and work arrays of another
#: (writable, C-ordered), so a structure without bodies, or with other sizes, calls the same
#: signatures (tests/sim/test_kernel_signatures.py).
WARM_STRUCTURE: dict[str, object] = {
    "name": "warm-up",
    "nodes": {"p1": [0, 0, 0], "p2": [1, 0, 0], "p3": [0, 1, 0], "n": [0.5, 0.5, 1.0], "s": [1.0, 1.0, 0.5]},
    "members": [{"nodes": ["p1", "n"], "EA": 50.0, "rest_length_ratio": 0.9},
                {"nodes": ["p2", "n"], "EA": 50.0, "rest_length_ratio": 0.9},
                {"nodes": ["p3", "n"], "type": "bar", "EA": 80.0},
                {"nodes": ["n", "s"], "EA": 30.0, "rest_length_ratio": 0.95}],
    "rigid_bodies": [{"name": "plate", "nodes": ["p1", "p2", "p3"], "mass": 1.0}],
    "pinned": {"s": "z"},
    "masses": {"n": 0.3, "s": 0.2},
}


def warm() -> float:
    """Run every compiled kernel once (compiling or loading it); the seconds it took."""
    from tensegrity_core.sim import Simulator, scene_from_dict
    from tensegrity_core.sim.general.kernels import loops

    started = time.perf_counter()
    _warm_general(WARM_STRUCTURE)
    gaps = np.zeros(1)
    loops.quiet_step(gaps, gaps, gaps, gaps, np.zeros(1, dtype=bool), 1e-3)   # as the tests call it
    robot = scene_from_dict({"model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
                             "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"],
                             "duration": 0.0025})
    Simulator(robot, t_end=robot.duration).advance(robot.duration)    # the robot kernels: steps, interpolation
    return time.perf_counter() - started


def _warm_general(structure: dict[str, object]) -> None:
    """Run every kernel of a general structure once: stepping, interpolation, the stages."""
    from tensegrity_core.sim import Simulator, scene_from_dict
    from tensegrity_core.sim.general.kernels.stages import CompiledStages
    from tensegrity_core.sim.general.model import GeneralSystem

    scene = scene_from_dict({"model": {"kind": "general", "structure": structure}, "initial": {"drawn": True},
                             "effects": ["inertia", "springs", {"damping": {"c": 0.1}},
                                         {"gravity": {"vector": [0.0, 0.0, -9.81]}}],
                             "duration": 0.01, "integrator": {"method": "DOP853", "rtol": 1e-6, "atol": 1e-8}})
    sim = Simulator(scene, t_end=scene.duration)
    sim.advance(scene.duration)                      # stepping, interpolation
    eq = sim.state.work.system
    assert isinstance(eq, GeneralSystem)
    y = sim.state.y.copy()
    eq.fun(0.0, y)
    eq.jac(0.0, y)
    eq.evaluate([0.0, 0.0], np.array([y, y]))
    stages = eq.stages
    assert isinstance(stages, CompiledStages)
    f = eq.fun(0.0, y)
    stages.rk4(0.0, y, f, 1e-3)
    y_new, K, _ = stages.dop853(0.0, y, f, 1e-3, 1e-6, 1e-8)
    stages.dop853_dense(0.0, y, y_new, K, 1e-3)
    samples = np.array([0.0025, 0.004, 0.0045, 0.01])
    stages.rk4_run(0.0, y, f, 1e-3, 0.01, 0.01, samples, 0)
    stages.dop853_run(0.0, y, f, 0.01, 0.01, 1e-3, np.inf, 1e-6, 1e-8, (0.9, 0.2, 10.0), samples, 0)


def main() -> int:
    if not have_numba():
        print("numba is not installed: the numpy kernels need no compiling")
        return 0
    cpu = time.process_time()
    took = warm()
    print(f"numba kernels ready in {took:.1f} s ({time.process_time() - cpu:.1f} s of CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
