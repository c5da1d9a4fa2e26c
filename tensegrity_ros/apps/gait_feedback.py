"""The closed-loop rolling gait over ROS, without ROS: the simulator's messages mapped to the
inputs of :class:`tensegrity_core.robot.roll_control.RollController` and its output to the
answers a ROS client publishes (``tensegrity gait ROBOT roll``; the node part is
:mod:`.gait_loop`).

- **Caps from poses** (:class:`RodFrames`): ``body_states`` gives each rod's pose, origin at
  the rod's centre (the mean of its two end nodes) and orientation the rotation from the
  robot description's drawing to now. A cap (end node) is therefore at
  ``centre + R (x_drawn - centre_drawn)``, ``x_drawn`` its drawn coordinates [m]: the centre
  +- half the rod's length along its current axis. Nodes on no rod listed are NaN.
- **Contacts**: ``contacts`` lists by node name the caps touching the floor.
- **Samples** (:class:`FeedbackLoop`): the poses and the contacts of one publication carry
  the same stamp; once both of a stamp are in, that is one sample (the client needs the
  contacts with every state: the simulator's ``state_rate`` at least its ``publish_rate``).
  Every sample is answered with one ``CableCommand`` stamped like it, so that a lockstep
  simulator steps on: at a control instant (the first sample at or after each ``1 / rate``
  s of simulation time from the first sample) the controller's rest lengths [m] of every
  actuated cable by name, otherwise an empty command (which changes nothing: the motors
  hold the last rest lengths). A state published again unchanged (same stamp) gets the same
  answer again; the controller sees each stamp once. A stamp earlier than the latest is a
  reset of the simulator under the loop: :class:`ClockWentBack`.
- **Time** is simulation time (the stamps), so the loop runs free-running and in lockstep
  alike; the controller sees it from the first sample (``t = 0``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.errors import TensegrityError
from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.roll_control import RollController

FloatArray = NDArray[np.float64]
NS_PER_S = 1_000_000_000


class ClockWentBack(TensegrityError, RuntimeError):
    """The simulation clock went back under the loop (a reset)."""


@dataclass(frozen=True)
class RodFrames:
    """Where each rod's caps sit in its body frame: ``body_names`` (the rods' names, as
    ``body_states`` names them), their ``ends`` (r, 2) node indices and ``offsets`` (r, 2, 3)
    [m] of the ends from the rod's centre in the drawing; ``n_nodes`` nodes in all."""

    body_names: tuple[str, ...]
    ends: NDArray[np.int64]
    offsets: FloatArray
    n_nodes: int

    @classmethod
    def of(cls, robot: Robot) -> RodFrames:
        """The rods of ``robot`` (module note)."""
        ends = np.asarray(robot.rods.ends, dtype=np.int64).reshape(-1, 2)
        drawn = np.asarray(robot.nodes, dtype=float)[ends]                  # (r, 2, 3)
        return cls(tuple(robot.rods.names), ends, drawn - drawn.mean(axis=1, keepdims=True), len(robot.node_names))

    def nodes(self, names: Sequence[str], positions: Sequence[Sequence[float]],
              quaternions: Sequence[Sequence[float]]) -> FloatArray:
        """The node positions (n, 3) [m, the poses' frame] from the poses of the bodies ``names``:
        centres ``positions`` (b, 3) [m], orientations ``quaternions`` (b, 4) (x, y, z, w, as
        geometry_msgs/Quaternion). NaN rows: nodes of no rod among ``names``."""
        out = np.full((self.n_nodes, 3), np.nan)
        index = {name: i for i, name in enumerate(self.body_names)}
        rows = [(index[name], k) for k, name in enumerate(names) if name in index]
        if rows:
            rods, msgs = (list(v) for v in zip(*rows))
            centre = np.asarray(positions, dtype=float).reshape(-1, 3)[msgs]
            rot = Rotation.from_quat(np.asarray(quaternions, dtype=float).reshape(-1, 4)[msgs])
            for side in (0, 1):
                out[self.ends[rods, side]] = centre + rot.apply(self.offsets[rods, side])
        return out


@dataclass
class Answer:
    """What to publish for the state stamped ``stamp_ns`` [ns]: the rest lengths [m]
    ``rest_lengths`` of ``names`` (both empty: no change)."""

    stamp_ns: int
    names: tuple[str, ...] = ()
    rest_lengths: tuple[float, ...] = ()


@dataclass
class FeedbackLoop:
    """The client's loop (module note): feed it the poses (:meth:`on_bodies`) and contacts
    (:meth:`on_contacts`) as they arrive; each returns the answers now due. ``cables``: the
    actuated cables' names in the controller's command order; ``node_names`` the robot's;
    ``rate`` [Hz] the control rate."""

    controller: RollController
    frames: RodFrames
    node_names: tuple[str, ...]
    cables: tuple[str, ...]
    rate: float = 50.0
    start_ns: int | None = None
    #: stamp [ns] of the first sample after which the controller was done (None: not yet)
    done_ns: int | None = None
    _bodies: dict[int, FloatArray] = field(default_factory=dict, repr=False)
    _contacts: dict[int, NDArray[np.int64]] = field(default_factory=dict, repr=False)
    _last: Answer | None = field(default=None, repr=False)
    _next_instant: int = field(default=0, repr=False)   # index k of the next control instant k / rate

    def __post_init__(self) -> None:
        if not (self.rate > 0 and np.isfinite(self.rate)):
            raise ValueError(f"the control rate must be a positive number of Hz, got {self.rate!r}")
        self._node_index = {name: i for i, name in enumerate(self.node_names)}

    def on_bodies(self, stamp_ns: int, names: Sequence[str], positions: Sequence[Sequence[float]],
                  quaternions: Sequence[Sequence[float]]) -> list[Answer]:
        """A ``body_states`` message: its stamp [ns], body names, centres [m] and orientations (x, y, z, w)."""
        self._bodies[stamp_ns] = self.frames.nodes(names, positions, quaternions)
        return self._pair(stamp_ns)

    def on_contacts(self, stamp_ns: int, names: Sequence[str]) -> list[Answer]:
        """A ``contacts`` message: its stamp [ns] and the names of the caps touching the floor
        (names of no node of the robot are ignored)."""
        self._contacts[stamp_ns] = np.array([self._node_index[n] for n in names if n in self._node_index],
                                            dtype=np.int64)
        return self._pair(stamp_ns)

    def _pair(self, stamp_ns: int) -> list[Answer]:
        if stamp_ns not in self._bodies or stamp_ns not in self._contacts:
            return []
        nodes, touching = self._bodies.pop(stamp_ns), self._contacts.pop(stamp_ns)
        for older in [s for s in (*self._bodies, *self._contacts) if s < stamp_ns]:   # their pair never comes
            self._bodies.pop(older, None)
            self._contacts.pop(older, None)
        return [self._answer(stamp_ns, touching, nodes)]

    def _answer(self, stamp_ns: int, touching: NDArray[np.int64], nodes: FloatArray) -> Answer:
        last = self._last
        if last is not None and stamp_ns == last.stamp_ns:
            return last                                    # the same state again: the same answer
        if last is not None and stamp_ns < last.stamp_ns:
            raise ClockWentBack(f"the simulation clock went back from {last.stamp_ns / NS_PER_S:.3f} s to "
                                f"{stamp_ns / NS_PER_S:.3f} s (the simulator was reset under the gait)")
        if self.start_ns is None:
            self.start_ns = stamp_ns
        since = stamp_ns - self.start_ns
        answer = Answer(stamp_ns)
        if since * self.rate >= self._next_instant * NS_PER_S:
            command = self.controller.update(since / NS_PER_S, touching, nodes)
            answer = Answer(stamp_ns, self.cables, tuple(float(v) for v in command))
            self._next_instant = int(since * self.rate // NS_PER_S) + 1
            if self.done_ns is None and self.controller.done:
                self.done_ns = stamp_ns
        self._last = answer
        return answer

    def elapsed(self) -> float:
        """Simulation time [s] from the first sample to the latest answered (0 before any)."""
        if self.start_ns is None or self._last is None:
            return 0.0
        return (self._last.stamp_ns - self.start_ns) / NS_PER_S
