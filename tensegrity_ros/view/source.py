"""What the view asks of a source of frames, and what the page offers for it.

A source produces :class:`~tensegrity_ros.view.frame.Frame` objects of one
:class:`~tensegrity_ros.view.frame.Topology` and carries out the page's requests. Requests
never block the page: they answer through ``report`` (one line shown in the page), at once
or when the simulator has answered. Three sources: a running suite over ROS
(:class:`~tensegrity_ros.view.ros_source.RosSource`), a bag (:class:`~tensegrity_ros.view.bag_source.BagSource`)
and the core simulator in the view's process (:class:`~tensegrity_ros.view.scene_source.SceneSource`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from tensegrity_ros.view.frame import Frame, Topology
from tensegrity_ros.view.inputs import InputSpec

Sink = Callable[[Frame], None]
Report = Callable[[str], None]

#: Features a source may offer (its ``features``): run control (play, pause), single steps,
#: inputs set from sliders, the class-2 controller's move of node D, a timeline (a bag).
FEATURES = ("run", "step", "inputs", "move", "timeline")


class Source(Protocol):
    """``topology``; ``label`` (what the page's title names); ``features`` (of :data:`FEATURES`);
    ``inputs`` (the sliders, empty without the ``"inputs"`` feature); ``duration`` [s] of a
    timeline (0 without one); ``tension_scale`` [N]: the top of the strings' colour scale when
    known in advance (a bag), else 0 (the largest tension seen so far)."""

    topology: Topology
    label: str
    features: frozenset[str]
    inputs: tuple[InputSpec, ...]
    duration: float
    tension_scale: float

    def first_frame(self, timeout: float) -> Frame:
        """The frame to show first (a live source waits up to ``timeout`` s for it and raises
        :class:`~tensegrity_ros.view.server.ViewError` without one)."""

    def start(self, sink: Sink, report: Report) -> None:
        """Begin sending frames to ``sink``; the first comes as soon as there is one."""

    def stop(self) -> None:
        """Stop sending frames and release what the source holds (the suite keeps running)."""

    def play(self) -> None: ...

    def pause(self) -> None: ...

    def step(self, steps: int) -> None:
        """Advance a paused simulation by ``steps`` steps."""

    def drive(self, values: dict[str, float] | None) -> None:
        """Hold the inputs at ``values`` (by input name; already within limits) from now on,
        or stop driving them (None)."""

    def move(self, x: float, y: float, duration: float) -> None:
        """The class-2 controller's ``move_end_effector`` goal: node D to (x, y) [m] in
        ``duration`` [s]."""

    def seek(self, t: float) -> None:
        """Show the timeline at ``t`` [s] from its start."""

    def set_rate(self, rate: float) -> None:
        """Play the timeline at ``rate`` times real time."""
