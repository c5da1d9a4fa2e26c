"""The simulator's plant: the core :class:`~tensegrity_core.sim.Simulator` and the
simulation clock, with no ROS in it.

Time is counted in whole steps of ``step_ns`` nanoseconds: after ``k`` steps the core is at
``step_time(k, step_ns)`` and the simulation clock (what ``/clock`` and every stamp say)
reads ``offset_ns + k * step_ns`` exactly. Each step is ``set_command(u)`` then
``advance(t_k+1)``, the same calls in the same order as the core's sampled-data runner
(:func:`tensegrity_core.sim.sampled.run_sampled`), so the two agree to the last bit.

A step that the core refuses (singular configuration, integrator failure) sets
:attr:`fault`: from then on the state is held and the clock still advances by one step
per step, until a reset.

What the model takes and reports comes from the model itself: its
:class:`~tensegrity_core.sim.model.Interface` (forces or rest lengths, which inputs take
commands, their ranges) and its names (members, rigid bodies).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from tensegrity_core.errors import TensegrityError
from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim import Names, Simulator, compile_scene
from tensegrity_core.sim.model import Interface
from tensegrity_core.sim.sampled import step_time
from tensegrity_core.sim.scene.spec import Scene
from tensegrity_core.sim.simulator import JointSample, Observation


@dataclass(frozen=True)
class StepOutcome:
    """What one step did: the events the integrator located in it (``(t [s] on the core's
    clock, kind, index)``), and the fault that stopped the simulation in it (or None)."""

    events: tuple[LoggedEvent, ...]
    fault: str | None = None


class SimPlant:
    """The simulation of one scene, stepped ``step_ns`` at a time."""

    def __init__(self, scene: Scene, step_ns: int) -> None:
        self.scene = scene
        self.step_ns = int(step_ns)
        self.offset_ns = 0
        self.model = compile_scene(scene)             # once: a reset is a new state of it
        self.interface: Interface = self.model.interface
        self.names: Names = self.model.names
        #: The scene adds sensor noise to what it observes.
        self.noisy = "sensor_noise" in scene.effects
        self._start()

    def _start(self) -> None:
        self.sim = Simulator(self.model)
        self.k = 0
        self.fault: str | None = None
        self._n_events = 0
        # Until the first command the actuators hold what the scene starts with (for the
        # default scene: the forces that keep the mechanism at rest); inputs that follow a
        # law of the scene hold a placeholder 0 that the core ignores.
        self.initial_command = [0.0 if math.isnan(f) else float(f) for f in self.sim.command]

    @property
    def time_ns(self) -> int:
        """The simulation clock [ns]."""
        return self.offset_ns + self.k * self.step_ns

    def reset(self, *, keep_time: bool) -> None:
        """Back to the scene's initial state; the clock goes on from where it is
        (``keep_time``) or back to 0."""
        self.offset_ns = self.time_ns if keep_time else 0
        self._start()

    def step(self, command: Iterable[float]) -> StepOutcome:
        """Integrate one step under ``command`` (one force per actuator [N]) held."""
        fault = None
        if self.fault is None:
            try:
                self.sim.set_command(command)
                self.sim.advance(step_time(self.k + 1, self.step_ns))
            except TensegrityError as err:
                self.fault = fault = str(err)
        self.k += 1
        events = self.sim.state.events          # the state's own log (``Simulator.events`` copies it)
        new, self._n_events = tuple(events[self._n_events:]), len(events)
        return StepOutcome(new, fault)

    def joint_sample(self, *, coordinates: bool = True) -> JointSample:
        """The core's joint sample (``coordinates=False``: ``q`` and ``qdot`` may be empty)."""
        return self.sim.joint_sample(coordinates=coordinates)

    def observe(self) -> Observation:
        return self.sim.observe()

    def floor(self) -> tuple[np.ndarray, np.ndarray] | None:
        """A robot's floor: ``(a point [m], its unit normal)``, or None (no floor, or not a robot)."""
        robot = getattr(self.model, "robot", None) if self.model.kind == "robot" else None
        if robot is None or robot.floor is None:
            return None
        return np.asarray(robot.floor.point, dtype=float), np.asarray(robot.floor.normal, dtype=float)

    def singular_distance(self) -> tuple[str, float] | None:
        """``(name, lambda/L)`` of the singular set nearest the current state (class-2), or None."""
        return self.sim.singular_distance()
