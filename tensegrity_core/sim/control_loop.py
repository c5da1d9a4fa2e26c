"""A model run under a sampled controller (a closed-loop gait).

:class:`ControlLoop` samples a :class:`Controller` at its rate: at each control instant it
reads the contact state (the caps whose normal force is positive) and the node positions,
sets the commanded inputs to the controller's command and holds them until the next
instant, as a robot's control loop does; between, the model advances at its own step.
:meth:`ControlLoop.record` records the run wherever asked (:func:`tensegrity_core.sim.simulate`:
a scene's output rate); :meth:`ControlLoop.run` at the control instants until the controller
is done.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.errors import ParameterError
from tensegrity_core.sim.model import Model, State
from tensegrity_core.sim.scene.robot_schema import control_rate_reason

FloatArray = NDArray[np.float64]


class Controller(Protocol):
    """A sampled controller: the motors' commands from the touching caps (node indices) and
    the node positions (n, 3) [m] at time ``t`` [s] (from the loop's start)."""

    @property
    def done(self) -> bool: ...

    def update(self, t: float, touching: NDArray[np.int64], nodes: FloatArray) -> FloatArray: ...


class ControlledModel(Model[Any, Any], Protocol):
    """A model a sampled controller runs: a robot's
    (:class:`~tensegrity_core.sim.general.robot.dynamic.RobotDynamic`), whose samples give the
    caps' normal forces [N] (ncap,) and the node positions [m] (n, 3) without a whole observation."""

    def contact_forces_and_nodes(self, sample: Any) -> tuple[FloatArray, FloatArray]: ...


class ControlLoop:
    """``controller`` sampled at ``rate`` [Hz] from ``state.t`` on, its commands held between
    samples; :meth:`record` records ``state`` at any instants meanwhile, :meth:`run` at the
    control instants. ``model`` gives the caps' contact forces in the order of its
    ``names.cap_names`` (a robot's). A rate the model's step cannot take is refused with ``ParameterError``
    (:func:`~tensegrity_core.sim.scene.robot_schema.control_rate_reason`), as a scene's
    ``control`` is."""

    def __init__(self, model: ControlledModel, state: State[Any], controller: Controller, *, rate: float):
        integrator = model.scene.integrator
        reason = control_rate_reason(rate, integrator.max_step if integrator.method == "RK4" else 0.0)
        if reason is not None:
            raise ParameterError(reason)
        self.model, self.state, self.controller, self.rate = model, state, controller, rate
        names = model.names
        self.caps = np.array([names.node_names.index(c) for c in names.cap_names], dtype=np.int64)
        self.t0 = state.t
        self.k = 0                      # the next control instant is t0 + k / rate

    def record(self, times: Sequence[float] | FloatArray, samples: list[Any]) -> None:
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

    def run(self, duration: float, *, after: float = 0.0) -> list[Any]:
        """The samples at the control instants from the next one on (each taken after its
        update), until the controller is done and ``after`` [s] more, or ``duration`` [s] in
        all."""
        samples: list[Any] = []
        last = self.k + round(duration * self.rate)
        finish: float | None = None
        while True:
            t = self.t0 + self.k / self.rate
            self.record([t], samples)
            if finish is None and self.controller.done:
                finish = t + after
            if self.k > last or (finish is not None and t >= finish - 1e-12):
                return samples

    def _update(self, t: float) -> None:
        """The controller's command at the control instant ``t`` [s], from the contact state
        and node positions there."""
        scratch: list[Any] = []
        self.model.record(self.state, [t], scratch)
        contact_forces, nodes = self.model.contact_forces_and_nodes(scratch[0])
        touching = self.caps[contact_forces > 0.0]
        self.model.set_command(self.state, self.controller.update(t - self.t0, touching, nodes))
        self.k += 1
