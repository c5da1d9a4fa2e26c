"""Frames from the core simulator run in the view's process (any scene: class-2 or general).

For structures the ROS suite does not simulate, and to watch a scene without starting the
suite: a thread steps :class:`tensegrity_core.sim.Simulator` in whole steps of ``step`` s at
real time (the steps due since the last tick, at most ``MAX_CATCH_UP`` s of them: a late
tick resynchronises instead of racing), and sends a frame per tick. A tick steps for at most
one tick period of wall time: a scene that computes slower than real time (a stiff one on a
loaded machine) runs slower, and the page still gets a frame every tick. Pause, play, single
steps and the commanded inputs (class-2 actuator forces [N], tension positive; rest lengths
[m] of a general structure's actuated members) act on that simulator; it starts paused.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Final

from tensegrity_core.errors import TensegrityError
from tensegrity_core.sim import Simulator, load_scene
from tensegrity_core.sim.sampled import step_time
from tensegrity_ros.view.frame import Frame
from tensegrity_ros.view.frames import frame_of_observation, scene_topology
from tensegrity_ros.view.inputs import InputSpec, command_input
from tensegrity_ros.view.source import Report, Sink

#: Largest simulated time made up in one tick [s].
MAX_CATCH_UP: Final = 0.25


def _ignore(_text: str) -> None:
    """A report nobody reads (before :meth:`SceneSource.start`)."""


class SceneSource:
    """The core simulator of ``scene`` (a shipped scene's name or a file), stepped every
    ``step`` s, ticking at ``rate`` Hz of wall time; ``force_limit`` [N] bounds the class-2
    force sliders."""

    def __init__(self, scene: str, *, step: float = 0.01, rate: float = 60.0, force_limit: float = 5.0):
        self.sim = Simulator(load_scene(scene))
        self.topology = scene_topology(self.sim.scene)
        self.label = f"scene {self.sim.scene.name} (core simulator in this process)"
        self.step_ns = max(1, round(step * 1e9))
        self.period = 1.0 / rate
        self.duration = 0.0
        self.tension_scale = 0.0
        self.inputs = self._input_specs(force_limit)
        self.features = frozenset({"run", "step"} | ({"inputs"} if self.inputs else set()))
        self._k = 0
        self._playing = False
        self._steps_wanted = 0
        self._frame_due = True      # a frame also when only the run state changed
        self._command = list(self.sim.command)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._report: Report = _ignore

    def _input_specs(self, force_limit: float) -> tuple[InputSpec, ...]:
        """One slider per commanded input (inputs with a law follow it: no slider): class-2
        forces within ``force_limit`` [N]; rest lengths, tensions or reel speeds within the
        simulator's limits (:func:`.inputs.command_input`)."""
        names = list(self.sim.scene.inputs)
        itf = self.sim.interface
        modes = itf.modes or ("rest_length",) * len(names)
        out = []
        for name, value, limits, mode in zip(names, self.sim.command, itf.limits, modes):
            if math.isnan(value):
                continue
            if self.topology.kind == "class2":
                out.append(InputSpec(name, "N", -force_limit, force_limit, float(value)))
            else:              # a robot motor's command in its mode, within its range
                out.append(command_input(name, float(value), limits, mode))
        return tuple(out)

    def first_frame(self, timeout: float = 0.0) -> Frame:
        return self._frame()

    def _frame(self) -> Frame:
        state = "playing" if self._playing else "paused"
        return frame_of_observation(self.sim.observe(), self.topology, state)

    def start(self, sink: Sink, report: Report) -> None:
        self._report = report
        self._thread = threading.Thread(target=self._run, args=(sink,), name="view_scene", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join()

    def _run(self, sink: Sink) -> None:
        next_tick = time.monotonic()
        last = next_tick
        while not self._stop.is_set():
            now = time.monotonic()
            with self._lock:
                due = 0
                if self._playing:
                    elapsed = min(now - last, MAX_CATCH_UP)
                    due = max(1, round(elapsed * 1e9 / self.step_ns))
                wanted, self._steps_wanted = self._steps_wanted, 0
                command = list(self._command)
            last = now
            if due + wanted:
                done = self._advance(due + wanted, command, deadline=now + self.period)
                with self._lock:     # requested steps not done in this tick: the next ones do them
                    self._steps_wanted += min(wanted, due + wanted - done)
            if due + wanted or self._frame_due:
                self._frame_due = False
                sink(self._frame())
            next_tick = max(next_tick + self.period, time.monotonic())
            self._wake.wait(max(0.0, next_tick - time.monotonic()))
            self._wake.clear()

    def _advance(self, steps: int, command: list[float], deadline: float) -> int:
        """Up to ``steps`` steps, until the monotonic clock passes ``deadline`` (one at least);
        the number of steps made (all of them after a failure: the simulation stops)."""
        try:
            if self.inputs:             # inputs that all follow their law take no command
                self.sim.set_command(command)
            for done in range(1, steps + 1):
                self._k += 1
                self.sim.advance(step_time(self._k, self.step_ns))
                if time.monotonic() > deadline:
                    return done
        except TensegrityError as err:
            with self._lock:
                self._playing = False
            self._report(f"the simulation stopped: {err}")
        return steps

    def play(self) -> None:
        with self._lock:
            self._playing = True
            self._frame_due = True
        self._report("playing")
        self._wake.set()

    def pause(self) -> None:
        with self._lock:
            self._playing = False
            self._frame_due = True
        self._report("paused")
        self._wake.set()

    def step(self, steps: int) -> None:
        with self._lock:
            if self._playing:
                self._report("stepping needs the simulation paused")
                return
            self._steps_wanted += int(steps)
        self._report(f"{steps} step{'s' * (steps != 1)} of {self.step_ns / 1e9:g} s")
        self._wake.set()

    def drive(self, values: dict[str, float] | None) -> None:
        names = list(self.sim.scene.inputs)
        with self._lock:
            if values is None:
                self._command = list(self.sim.command)
                return
            for name, value in values.items():
                self._command[names.index(name)] = float(value)

    def move(self, x: float, y: float, duration: float) -> None:
        self._report("moving node D needs the controller of a running suite (tensegrity up)")

    def seek(self, t: float) -> None:
        self._report("no timeline: this is a live simulation")

    def set_rate(self, rate: float) -> None:
        self._report("no timeline: this is a live simulation")

