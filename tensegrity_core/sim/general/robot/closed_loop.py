"""A robot scene run under a sampled controller (a closed-loop gait).

:func:`run_controlled` advances a compiled robot scene at the controller's rate: at each
control sample it reads the contact state (caps whose normal force is positive) and the node
positions, asks the controller for the motors' commands and holds them until the next
sample, as a robot's control loop does (the physics runs at its own fixed step between).
(:class:`tensegrity_core.sim.control_loop.ControlLoop` does the same while recording at
other instants: what :func:`tensegrity_core.sim.simulate` runs for a scene with ``control``.)
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.control_loop import Controller
from tensegrity_core.sim.general.robot.dynamic import RobotDynamic
from tensegrity_core.sim.general.robot.stepping import FixedStepper, RobotSample
from tensegrity_core.sim.model import State

FloatArray = NDArray[np.float64]


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

