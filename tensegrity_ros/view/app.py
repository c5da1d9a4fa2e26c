"""The view: a server, the drawing, the plots, the controls and a source, wired together.

Sources call :meth:`View.submit` from their own threads as often as frames come; a render
thread sends the page the newest frame at most ``fps`` times a second, the sends on a grid
of ``1/fps`` s (:mod:`.pacing`: the time a send takes and a late wake-up are within the
period, not added to it), and frames in between only extend the plots' history, so a fast
simulator never floods the page. Closing the
page changes nothing; :meth:`View.close` stops the source and the server, never the suite.
"""

from __future__ import annotations

import functools
import math
import threading
import time
from typing import Any, Final

import numpy as np

from tensegrity_ros.view import resolution
from tensegrity_ros.view.controls import ControlPanel
from tensegrity_ros.view.drawing import StructureDrawing
from tensegrity_ros.view.frame import Frame
from tensegrity_ros.view.pacing import Pacer
from tensegrity_ros.view.plots import PlotPanel, SeriesHistory
from tensegrity_ros.view.source import Source

#: The plots are sent at most every this many seconds [s] while frames come (each sends the
#: whole plotted history, which the page redraws: sent with every few frames, it took a
#: quarter of the frame rate of a page on software WebGL, docs/design/view.md),
PLOT_PERIOD: Final = 0.5
#: and when no new frame has come for this long [s] after one that did not send them.
QUIET: Final = 0.25


def status_line(frame: Frame) -> str:
    """The page's status: simulation time [s] and run state."""
    return f"**t = {frame.t:.3f} s** · {frame.run_state}"


def _set(handle: Any, content: str) -> None:
    """Send a GUI text only when it changed (every message re-renders the page's panel)."""
    if handle.content != content:
        handle.content = content


class View:
    """A started view of ``source`` on ``server`` (see the module docstring); ``first`` is the
    source's first frame (the drawing's sizes and the camera come from it)."""

    def __init__(self, server: Any, source: Source, first: Frame, *, fps: float = 60.0):
        self.server = server
        self.source = source
        self.pacer = Pacer(1.0 / fps)
        resolution.install(server, fps)
        gui = server.gui
        gui.add_markdown(f"**{source.label}**")
        self.status = gui.add_markdown(status_line(first))
        self.message = gui.add_markdown("")
        self.controls = ControlPanel(gui, source, self.report)
        self.history = SeriesHistory()
        self.plots = PlotPanel(gui, source.topology, self.history)
        self.drawing = StructureDrawing(server.scene, source.topology, first, tension_scale=source.tension_scale)
        self.legend = gui.add_html(self.drawing.legend(), order=-1)
        self._place_camera(first.nodes)
        self._latest: Frame | None = first
        self._t0 = first.t if "timeline" in source.features else 0.0
        self._cond = threading.Condition()
        self._closing = False
        self.frames_shown = 0
        self._thread = threading.Thread(target=self._render, name="view_render", daemon=True)
        self._thread.start()
        source.start(self.submit, self.report)

    def _place_camera(self, nodes: np.ndarray) -> None:
        """Planar structures (all z equal) seen from above, slightly tilted; others from the front."""
        centre = 0.5 * (nodes.min(axis=0) + nodes.max(axis=0))
        planar = float(np.ptp(nodes[:, 2])) < 1e-9 * self.drawing.size
        offset = np.array([0.0, -0.35, 1.0]) if planar else np.array([0.6, -1.2, 0.7])
        camera = self.server.initial_camera
        camera.look_at = tuple(centre)
        camera.position = tuple(centre + offset * 1.6 * self.drawing.size)

    def report(self, text: str) -> None:
        """Show one line in the page (a request's answer, a clamped value)."""
        self.message.content = text

    def submit(self, frame: Frame) -> None:
        """A new frame (any thread)."""
        with self._cond:
            self.history.add(frame)
            self._latest = frame
            self._cond.notify()

    def _news_since(self, shown: Frame | None) -> bool:
        """Whether there is a frame other than ``shown`` to draw, or the view closes."""
        return self._closing or self._latest is not shown

    def _render(self) -> None:
        last: Frame | None = None
        stale = False                     # frames shown since the plots and the legend were sent
        plotted = -math.inf               # when they were sent [s, monotonic]
        while True:
            with self._cond:
                news = self._cond.wait_for(functools.partial(self._news_since, last), timeout=QUIET if stale else 1.0)
                if self._closing:
                    return
                frame = self._latest
            if not news and stale:        # the source went quiet (paused, a jump on a timeline)
                with self.server.atomic():
                    self._refresh_panel()
                self.server.flush()
                stale = False
            if frame is None or frame is last:
                continue
            if last is not None and frame.t < last.t:
                self.drawing.clear_trail()
            deadline = self.pacer.tick(time.monotonic())
            with self.server.atomic():
                self.drawing.show(frame)
                _set(self.status, status_line(frame))
                self.controls.show_time(frame.t - self._t0)
                now = time.monotonic()
                stale = now - plotted < PLOT_PERIOD
                if not stale:
                    self._refresh_panel()
                    plotted = now
            self.server.flush()
            self.frames_shown += 1
            last = frame
            self._stop_wait(deadline - time.monotonic())

    def _refresh_panel(self) -> None:
        """Send the plots their history and the legend its scales (call within ``atomic()``)."""
        with self._cond:
            self.plots.refresh()
        _set(self.legend, self.drawing.legend())

    def _stop_wait(self, seconds: float) -> None:
        with self._cond:
            self._cond.wait_for(lambda: self._closing, timeout=seconds)

    def close(self) -> None:
        """Stop the source, the render thread and the server."""
        self.source.stop()
        with self._cond:
            self._closing = True
            self._cond.notify_all()
        self._thread.join()
        self.server.stop()
