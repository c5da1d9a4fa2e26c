"""Sampled-data runs: a controller evaluated at ``t_k = k h``, its output held for one period.

This is the loop a lockstep ROS simulator closes with a controller in another process,
here in one call. For ``k = 0, 1, ..., n - 1``::

    sample = sim.joint_sample()      # the state at t_k
    u_k = controller(sample)         # forces [N] (tension positive), one per input
    sim.set_command(u_k)             # zero-order hold on [t_k, t_k+1)
    sim.advance(step_time(k + 1, step_ns))

Times are whole nanoseconds: ``t_k = k * step_ns / 1e9``, an exact integer product and
one correctly rounded division, never a float step accumulated ``k`` times (that drifts
by an ulp per step and two programs adding in different orders disagree). The ROS
simulator (``tensegrity_sim`` with ``lockstep: true``) calls the core in this same order
with these same times, so a lockstep ROS run and :func:`run_sampled` give the same floats
to the last bit. Only the public :class:`~tensegrity_core.sim.simulator.Simulator` API is
used here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.errors import TensegrityError
from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.model import Stats
from tensegrity_core.sim.scene import SceneSource, load_scene
from tensegrity_core.sim.simulator import JointSample, Simulator

NS_PER_S = 1_000_000_000
#: Longest run :func:`run_sampled` accepts [steps] (a typo in a period must not hang a shell).
MAX_STEPS = 10_000_000

#: A controller: the joint sample at ``t_k`` -> one command value per scene input.
Controller = Callable[[JointSample], Sequence[float]]


def step_ns_of(step_size: float) -> int:
    """A control period [s] as whole nanoseconds (rounded; at least 1 ns)."""
    if isinstance(step_size, bool) or not isinstance(step_size, (int, float)) or not math.isfinite(step_size) \
            or step_size <= 0:
        raise SimulationError(f"control period must be a positive number of seconds, got {step_size!r}")
    ns = round(step_size * NS_PER_S)
    if ns < 1:
        raise SimulationError(f"control period {step_size!r} s is below one nanosecond")
    return ns


def step_time(k: int, step_ns: int) -> float:
    """``t_k`` [s] of step ``k`` with a period of ``step_ns`` nanoseconds (see the module note)."""
    return k * step_ns / NS_PER_S


def steps_in(duration: float, step_ns: int) -> int:
    """Number of whole periods that cover ``duration`` [s] (the last may end past it by less
    than one period; a duration on the grid to within 1 ns counts exactly)."""
    return max(0, math.ceil((duration * NS_PER_S - 1.0) / step_ns))


@dataclass
class SampledRun:
    """The outcome of :func:`run_sampled`.

    ``times`` (n+1,) [s] are ``t_0 .. t_n``; ``samples`` the joint samples there (q, qdot,
    applied forces, end effector); ``commands`` (n, inputs) what the controller returned at
    ``t_0 .. t_n-1`` (held on each period); ``events`` ``(t, kind, index)`` as located by the
    integrator. A run that stops early (``success`` false, ``message`` why) has fewer steps.
    """

    scene_name: str
    step_ns: int
    times: NDArray[np.float64]
    samples: list[JointSample]
    commands: NDArray[np.float64]
    events: list[LoggedEvent]
    success: bool = True
    message: str = ""
    stats: Stats = field(default_factory=Stats)

    @property
    def q(self) -> NDArray[np.float64]:
        return np.array([s.q for s in self.samples])

    @property
    def qdot(self) -> NDArray[np.float64]:
        return np.array([s.qdot for s in self.samples])

    def to_npz(self, path: str | Path) -> None:
        """Write times, q, qdot, applied forces and commands to an ``.npz`` file."""
        np.savez(path, times=self.times, q=self.q, qdot=self.qdot,
                 applied_forces=np.array([s.applied_forces for s in self.samples]),
                 commands=self.commands, step_ns=self.step_ns)

    def to_csv(self, path: str | Path) -> None:
        """One row per ``t_k``: t, q, qdot, applied forces, and the command held from there."""
        n = len(self.samples)
        width = self.commands.shape[1] if self.commands.ndim == 2 else 0
        cmd = np.full((n, width), np.nan)
        cmd[:len(self.commands)] = self.commands
        forces = np.array([s.applied_forces for s in self.samples])
        q, qd = self.q, self.qdot
        cols = ["t"] + [f"q{i}" for i in range(q.shape[1])] + [f"qdot{i}" for i in range(qd.shape[1])] \
            + [f"applied{i}" for i in range(forces.shape[1])] + [f"command{i}" for i in range(width)]
        np.savetxt(path, np.column_stack([self.times, q, qd, forces, cmd]), delimiter=",",
                   header=",".join(cols), comments="")


def run_sampled(scene: SceneSource, controller: Controller, *, step_size: float | None = None,
                step_ns: int | None = None, steps: int | None = None, duration: float | None = None,
                stop: Callable[[], bool] | None = None) -> SampledRun:
    """Run ``scene`` under ``controller`` sampled every period and held in between.

    Give the period as ``step_size`` [s] or ``step_ns``, and the length as ``steps`` or
    ``duration`` [s] (default: the scene's duration). The scene's commanded inputs take the
    controller's values (values for inputs with a law of their own are ignored, as by
    :meth:`Simulator.set_command`). The simulator is open-ended (no ``t_end``), exactly as in
    the ROS node, so that the integrator takes the same steps in both. ``stop()`` is asked
    before each step: once it is true the run ends with the steps made so far (``success``
    False, message ``"interrupted at t = ... s"``).
    """
    scene = load_scene(scene)
    if (step_size is None) == (step_ns is None):
        raise SimulationError("give the control period as step_size [s] or step_ns, not both or neither")
    if step_size is not None:          # (then step_ns is None)
        step_ns = step_ns_of(step_size)
    elif isinstance(step_ns, bool) or not isinstance(step_ns, int) or step_ns < 1:
        raise SimulationError(f"step_ns must be a positive integer, got {step_ns!r}")
    if steps is None:
        steps = steps_in(scene.duration if duration is None else duration, step_ns)
    if isinstance(steps, bool) or not isinstance(steps, int) or not 0 <= steps <= MAX_STEPS:
        raise SimulationError(f"steps must be an integer in [0, {MAX_STEPS}], got {steps!r}")
    sim = Simulator(scene)
    samples = [sim.joint_sample()]
    commands: list[list[float]] = []
    success, message = True, f"{steps} steps of {step_ns} ns"
    for k in range(steps):
        if stop is not None and stop():
            success, message = False, f"interrupted at t = {step_time(k, step_ns):.9g} s"
            break
        try:
            u = [float(v) for v in controller(samples[-1])]
        except Exception as err:  # the controller is user code: say where it failed
            raise SimulationError(f"controller failed at t = {step_time(k, step_ns):.9g} s (step {k}): "
                                  f"{type(err).__name__}: {err}", t=step_time(k, step_ns)) from err
        try:
            sim.set_command(u)
        except TensegrityError as err:
            raise SimulationError(f"controller output at t = {step_time(k, step_ns):.9g} s (step {k}) is not a "
                                  f"command: {err}", t=step_time(k, step_ns)) from None
        commands.append(u)
        try:
            sim.advance(step_time(k + 1, step_ns))
        except TensegrityError as err:
            success, message = False, str(err)
            break
        samples.append(sim.joint_sample())
    times = np.array([step_time(k, step_ns) for k in range(len(samples))])
    width = len(scene.inputs)
    return SampledRun(scene.name, step_ns, times, samples, np.array(commands, dtype=float).reshape(-1, width),
                      sim.events, success, message, sim.stats())
