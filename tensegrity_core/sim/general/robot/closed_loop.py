"""A robot scene run under a sampled controller (a closed-loop gait).

:func:`run_controlled` advances a compiled robot scene at the controller's rate: at each
control sample it reads the contact state (caps whose normal force is positive) and the node
positions, asks the controller for the motors' commands and holds them until the next
sample, as a robot's control loop does (the physics runs at its own fixed step between).
:class:`ControlLoop` does the same while recording at other instants (a scene's output rate):
what :func:`tensegrity_core.sim.simulate` runs for a scene with ``control``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.robot.dynamic import RobotDynamic
from tensegrity_core.sim.general.robot.stepping import FixedStepper, RobotSample
from tensegrity_core.sim.model import State

FloatArray = NDArray[np.float64]


class Controller(Protocol):
    """A sampled controller: the motors' commands from the touching caps (node indices) and
    the node positions (n, 3) [m] at time ``t`` [s]."""

    @property
    def done(self) -> bool: ...

    def update(self, t: float, touching: NDArray[np.int64], nodes: FloatArray) -> FloatArray: ...


def run_controlled(model: RobotDynamic, state: State[FixedStepper], controller: Controller, *, rate: float,
                   duration: float, after: float = 0.0) -> list[RobotSample]:
    """Run ``state`` under ``controller`` sampled at ``rate`` [Hz] until the controller is done
    and ``after`` [s] more, or ``duration`` [s] in all; the samples at the control instants."""
    if not (rate > 0 and math.isfinite(rate)):
        raise ValueError(f"the control rate must be a positive number of Hz, got {rate!r}")
    caps = model.plan.cap_node
    samples: list[RobotSample] = []
    t0, steps = state.t, int(round(duration * rate))
    finish: float | None = None
    for k in range(steps + 1):
        t = t0 + k / rate
        model.record(state, [t], samples)
        seen = model.observe([samples[-1]])
        touching = caps[seen["contact_forces"][0] > 0.0]
        model.set_command(state, controller.update(t - t0, touching, seen["nodes"][0]))
        if finish is None and controller.done:
            finish = t + after
        if k == steps or (finish is not None and t >= finish - 1e-12):
            break
        model.advance(state, t0 + (k + 1) / rate)
    return samples


class ControlLoop:
    """``controller`` sampled at ``rate`` [Hz] from ``state.t`` on, its commands held between
    samples; :meth:`record` records ``state`` at any instants meanwhile."""

    def __init__(self, model: RobotDynamic, state: State[FixedStepper], controller: Controller, *, rate: float):
        if not (rate > 0 and math.isfinite(rate)):
            raise ValueError(f"the control rate must be a positive number of Hz, got {rate!r}")
        self.model, self.state, self.controller, self.rate = model, state, controller, rate
        self.t0 = state.t
        self.k = 0                      # the next control sample is at t0 + k / rate

    def record(self, times: Sequence[float] | FloatArray, samples: list[RobotSample]) -> None:
        """Advance to each of ``times`` [s] (increasing, from ``state.t``) and append its sample
        to ``samples``, updating the command at every control instant on the way (a sample
        at a control instant is taken after the update)."""
        times = np.asarray(times, dtype=float)
        i = 0
        while i < len(times):
            tc = self.t0 + self.k / self.rate
            if tc <= times[i] + 1e-12:
                self._update(tc)
                continue
            j = i + int(np.searchsorted(times[i:], tc - 1e-12))
            self.model.record(self.state, times[i:j], samples)
            i = j

    def _update(self, t: float) -> None:
        """The controller's command at the control instant ``t`` [s], from the contact state
        and node positions there."""
        scratch: list[RobotSample] = []
        self.model.record(self.state, [t], scratch)
        seen = self.model.observe(scratch)
        touching = self.model.plan.cap_node[seen["contact_forces"][0] > 0.0]
        self.model.set_command(self.state, self.controller.update(t - self.t0, touching, seen["nodes"][0]))
        self.k += 1
