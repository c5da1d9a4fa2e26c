"""``python -m tensegrity_core.sim.general.kernels.warm``: compile every numba kernel into its
on-disk cache, once (``./run setup`` does it after installing numba or changing a kernel).

numba compiles a kernel the first time a process calls it and, with ``cache=True``, keeps
the machine code next to the sources, where every later process (test workers, the demo,
the ROS nodes) loads it in a fraction of a second. Compiling all of them (47 kernels, 49
signatures) takes about 60 s of CPU; in ``./run setup`` it shares the two cores with the
interface builds, the byte-compilation and mypy, and is the set-up's last step, so it runs in two
processes: first the kernels both back ends call (the general right-hand side, ~10 s of CPU), then
the robot back end's (~21 s) in a forked process beside the rest of the general ones (~26 s).
The two compile disjoint kernels, so neither writes a cache file of the other's. The line it
prints gives the wall time and the CPU of both processes. Doing it here keeps that cost out of the first simulation a user runs and out of
parallel test workers that would each compile the same kernels at once.
"""

from __future__ import annotations

import os
import sys
import time
import traceback

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
    """Run every compiled kernel once (compiling or loading it); the seconds it took. The robot
    back end's kernels compile in a forked process (where the platform forks) beside the general
    ones, after the kernels both call; this process then loads them from the cache, so that it
    holds every kernel as a serial warm-up would (tests/sim/test_kernel_signatures.py)."""
    from tensegrity_core.sim.general.kernels import loops

    started = time.perf_counter()
    _warm_shared(WARM_STRUCTURE)
    child = os.fork() if hasattr(os, "fork") else None
    if child == 0:                                   # the forked process: the robot kernels, then exit
        code = 0
        try:
            _warm_robot()
        except BaseException:
            traceback.print_exc()
            code = 1
        finally:
            os._exit(code)
    _warm_general(WARM_STRUCTURE)
    gaps = np.zeros(1)
    loops.quiet_step(gaps, gaps, gaps, gaps, np.zeros(1, dtype=bool), 1e-3)   # as the tests call it
    if child is not None and os.waitstatus_to_exitcode(os.waitpid(child, 0)[1]) != 0:
        raise RuntimeError("compiling the robot kernels failed (its traceback is above)")
    _warm_robot()                                    # compiled by the forked process: loaded here
    return time.perf_counter() - started


def _warm_shared(structure: dict[str, object]) -> None:
    """The general right-hand side of ``structure``: ``derivative`` and the kernels it calls, which
    the robot kernels call too (``place``, ``rates``, ``nodal_wrenches``, ``rotate``)."""
    from tensegrity_core.sim import Simulator, scene_from_dict

    scene = scene_from_dict({"model": {"kind": "general", "structure": structure}, "initial": {"drawn": True},
                             "effects": ["inertia", "springs", {"damping": {"c": 0.1}},
                                         {"gravity": {"vector": [0.0, 0.0, -9.81]}}], "duration": 0.01})
    state = Simulator(scene, t_end=scene.duration).state
    state.work.system.fun(0.0, state.y.copy())


def _warm_robot() -> None:
    """Run every kernel of the robot back end once: a short three-bar run with every effect."""
    from tensegrity_core.sim import Simulator, scene_from_dict

    robot = scene_from_dict({"model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
                             "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"],
                             "duration": 0.0025})
    Simulator(robot, t_end=robot.duration).advance(robot.duration)    # steps, interpolation


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
    before = os.times()
    took = warm()
    after = os.times()
    cpu = sum(after[:4]) - sum(before[:4])           # this process's and the forked one's
    print(f"numba kernels ready in {took:.1f} s ({cpu:.1f} s of CPU in two processes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
