"""The page's controls, each turned into a request to the :class:`~tensegrity_ros.view.source.Source`.

Run control (play, pause, a number of steps), one slider per input (actuator forces [N],
tension positive; rest lengths [m]) with a checkbox that hands the inputs to the sliders,
the class-2 controller's move of node D (x, y [m], duration [s]) and, for a bag, a
timeline (time [s], rate). A value outside its limits (typed into a slider's field) is
clamped and the page says so (:func:`~tensegrity_ros.view.inputs.clamp`). Callbacks of
changes the server made itself (``event.client is None``) are not requests.
"""

from __future__ import annotations

from typing import Any

from tensegrity_ros.view.inputs import clamp
from tensegrity_ros.view.source import Report, Source


class ControlPanel:
    """The controls for ``source`` in the GUI ``gui``; ``report`` shows a line in the page."""

    def __init__(self, gui: Any, source: Source, report: Report):
        self.gui = gui
        self.source = source
        self.report = report
        self.timeline: Any = None              # the timeline's slider, when the source has one
        features = source.features
        if "timeline" in features:
            self._timeline()
        if "run" in features:
            self._run_control()
        if "inputs" in features:
            self._inputs()
        if "move" in features:
            self._move()

    def _run_control(self) -> None:
        gui, source = self.gui, self.source
        with gui.add_folder("Simulation"):
            play = gui.add_button("Play")
            pause = gui.add_button("Pause")
            play.on_click(lambda _e: source.play())
            pause.on_click(lambda _e: source.pause())
            if "step" in source.features:
                steps = gui.add_number("steps", initial_value=1, min=1, max=100000, step=1)
                step = gui.add_button("Step")
                step.on_click(lambda _e: source.step(int(steps.value)))

    def _inputs(self) -> None:
        gui, source = self.gui, self.source
        self.sliders = {}
        with gui.add_folder("Inputs"):
            drive = gui.add_checkbox("drive from the sliders", initial_value=False,
                                     hint="hold the inputs at the sliders' values (class-2: stop the controller first)")
            for spec in source.inputs:
                span = spec.high - spec.low
                slider = gui.add_slider(f"{spec.name} [{spec.unit}]", min=spec.low, max=spec.high,
                                        step=span / 1000, initial_value=spec.initial)
                self.sliders[spec.name] = (spec, slider)
            self.note = gui.add_markdown("")

        def values() -> dict[str, float]:
            # clamped here too: viser runs callbacks on a pool of threads, so another control's
            # callback can read a slider before that slider's own callback has clamped it
            return {name: clamp(spec, s.value, spec.initial).value for name, (spec, s) in self.sliders.items()}

        def on_drive(event: Any) -> None:
            if event.client is not None:
                source.drive(values() if drive.value else None)

        def on_slider(event: Any, name: str) -> None:
            if event.client is None:
                return
            spec, slider = self.sliders[name]
            clamped = clamp(spec, slider.value, spec.initial)
            self.note.content = clamped.note
            if clamped.note:
                self.report(clamped.note)
                slider.value = clamped.value
            if drive.value:
                source.drive(values())

        drive.on_update(on_drive)
        for name, (_spec, slider) in self.sliders.items():
            slider.on_update(lambda e, n=name: on_slider(e, n))

    def _move(self) -> None:
        gui, source = self.gui, self.source
        with gui.add_folder("Move node D"):
            x = gui.add_number("x [m]", initial_value=1.45, step=0.01)
            y = gui.add_number("y [m]", initial_value=0.72, step=0.01)
            duration = gui.add_number("duration [s]", initial_value=2.0, min=0.05, max=600.0, step=0.1)
            goal = gui.add_markdown("")
            go = gui.add_button("Move D")
            go.on_click(lambda _e: source.move(float(x.value), float(y.value), float(duration.value)))

        def show_goal(_event: Any = None) -> None:     # what Move D sends, as the server has it
            goal.content = f"goal: D to ({x.value:g}, {y.value:g}) m in {duration.value:g} s"

        show_goal()
        for field in (x, y, duration):
            field.on_update(show_goal)

    def _timeline(self) -> None:
        gui, source = self.gui, self.source
        with gui.add_folder("Timeline"):
            timeline = gui.add_slider("time [s]", min=0.0, max=max(source.duration, 1e-3),
                                      step=max(source.duration, 1e-3) / 1000, initial_value=0.0)
            rate = gui.add_number("rate [x real time]", initial_value=1.0, min=0.01, max=100.0, step=0.1)
        self.timeline = timeline

        def seek(event: Any) -> None:           # a user moved the slider (not show_time)
            if event.client is not None:
                source.seek(float(timeline.value))

        def set_rate(event: Any) -> None:
            if event.client is not None:
                source.set_rate(float(rate.value))

        timeline.on_update(seek)
        rate.on_update(set_rate)

    def show_time(self, t: float) -> None:
        """Move the timeline's slider to ``t`` [s] from the start (no request to the source)."""
        if self.timeline is not None:
            self.timeline.value = min(max(t, 0.0), self.timeline.max)
