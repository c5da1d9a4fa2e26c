"""Closed-loop verification: the core's controller against the scene simulator.

The loop is sampled as a real controller is: at ``t_k = k dt`` the law is evaluated on the
simulator's state, its output is held for one period (``Simulator.set_command``, then
``advance(t_k+1)``). The scene is the ROS node's default (``class2_at_rest``: the
mechanism at rest, commanded forces, springs, dampers, fold limit), started where the
study needs it.

- :func:`waypoint_study`: the demo's end-effector waypoints, each a move of ``move_time``
  seconds then ``settle_time`` seconds of hold; per move the settled error, settling time,
  overshoot, peak force and tracking error;
- :func:`circle_study`: D traces a circle; RMS and maximum tracking error.

Both run either the :class:`~tensegrity_core.class2.control.TrackingController`
(``law="lqr"``) or the demo's present law, :class:`~tensegrity_core.class2.control.ActuatorTracker`
with the demo's gains and its reference (a smoothstep in the actuator lengths between IK
solutions; on the circle, the IK of D's path at each tick) (``law="baseline"``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Final, TypeAlias

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.control.baseline import ActuatorTracker
from tensegrity_core.class2.control.law import TrackingController
from tensegrity_core.class2.control.lqr import DEFAULT_WEIGHTS, LQRWeights
from tensegrity_core.class2.control.paths import CirclePath
from tensegrity_core.class2.control.planner import plan_move, plan_path
from tensegrity_core.class2.inverse_kinematics import nearest_solution
from tensegrity_core.class2.kinematics import forward_kinematics
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import ParameterError

if TYPE_CHECKING:
    from tensegrity_core.sim.simulator import JointSample

#: The demo's end-effector waypoints: offsets [m] from D at rho = (0.7, 0.7).
WAYPOINT_OFFSETS: Final = ((0.08, 0.0), (0.08, 0.06), (-0.04, 0.06), (0.0, 0.0))
#: The demo's present law and gains (tensegrity_ros/demo.py).
BASELINE_GAINS: Final = dict(kp=100.0, kd=20.0, kbeta=0.3)
LAWS: Final = ("lqr", "baseline")

#: Two floats: forces (f1, f2) [N] or a point (x, y) [m].
Pair: TypeAlias = Sequence[float] | NDArray[np.float64]
#: A law of the loop: the sample at ``t_k`` -> (forces (f1, f2) [N], desired D (x, y) [m]).
Law: TypeAlias = "Callable[[JointSample], tuple[Pair, Pair]]"


@dataclass
class Trace:
    """Per tick: time [s], measured D (x, y) [m], desired D [m], commanded forces [N]."""

    t: list[float] = field(default_factory=list)
    D: list[NDArray[np.float64]] = field(default_factory=list)
    desired: list[NDArray[np.float64]] = field(default_factory=list)
    forces: list[NDArray[np.float64]] = field(default_factory=list)

    def arrays(self) -> dict[str, NDArray[np.float64]]:
        return {k: np.asarray(getattr(self, k)) for k in ("t", "D", "desired", "forces")}


@dataclass(frozen=True)
class MoveResult:
    """One move of :func:`waypoint_study` (lengths in m, times in s, forces in N)."""

    target: tuple[float, ...]
    start: tuple[float, ...]
    move_end: float              # time the move's reference reaches the target
    settled_error: float         # |D - target| settle_time after the move's end
    settling_time: float         # after the move's end until |D - target| stays below tolerance (inf: never)
    settling_time_2pc: float     # ... below 2 % of the move's length (the textbook settling band)
    overshoot: float             # largest excursion of D beyond the target along the move direction (>= 0)
    max_force: float             # largest |f| commanded during the move and its hold
    max_tracking_error: float    # largest |D - desired| during the move and its hold


@dataclass
class StudyResult:
    law: str
    rate: float
    moves: list[MoveResult]
    trace: Trace
    extra: dict[str, float] = field(default_factory=dict)


def at_rest_scene(rho1: float, rho2: float, params: Class2Params) -> dict[str, Any]:
    """The ``class2_at_rest`` scene started at rest at ``(rho1, rho2)`` with ``params``."""
    from tensegrity_core.schema import plain, read_file
    from tensegrity_core.sim import SceneError, scene_path

    data: dict[str, Any] = plain(read_file(scene_path("class2_at_rest"), error=SceneError, what="scene file")[0])
    data["model"]["params"] = params.as_dict()
    data["initial"] = {"equilibrium": {"rho1": float(rho1), "rho2": float(rho2)}}
    return data


class _Loop:
    """The sampled-data loop: law at t_k on the simulator's state, output held one period."""

    def __init__(self, scene: dict[str, Any], rate: float) -> None:
        from tensegrity_core.sim import Simulator

        if not (math.isfinite(rate) and rate > 0):
            raise ParameterError(f"rate must be a finite number > 0 Hz, got {rate!r}")
        self.sim = Simulator(scene)
        self.dt = 1.0 / rate
        self.k = 0
        self.trace = Trace()

    def sample(self) -> JointSample:
        return self.sim.joint_sample()

    def run(self, t_end: float, law: Law) -> None:
        """``law(sample) -> (forces, desired D)`` every period until ``t_end`` [s]."""
        while self.k * self.dt < t_end - 1e-9:
            s = self.sim.joint_sample()
            f, desired = law(s)
            self.trace.t.append(s.t)
            self.trace.D.append(s.end_effector[:2].copy())
            self.trace.desired.append(np.asarray(desired, dtype=float))
            self.trace.forces.append(np.asarray(f, dtype=float))
            self.sim.set_command([float(f[0]), float(f[1])])
            self.k += 1
            self.sim.advance(self.k * self.dt)


def _lqr_law(ctrl: TrackingController) -> Law:
    def law(s: JointSample) -> tuple[Pair, Pair]:
        tick = ctrl.update(s.t, s.q, s.qdot)
        return tick.forces, tick.desired.end_effector
    return law


@dataclass(frozen=True)
class _Smoothstep:
    """The baseline's length reference of one move: a smoothstep from ``start`` to ``goal``
    (rho1, rho2) [m] taking ``duration`` [s] from ``t0`` [s]."""

    start: NDArray[np.float64]
    goal: NDArray[np.float64]
    t0: float
    duration: float

    def __call__(self, t: float) -> NDArray[np.float64]:
        u = min(max((t - self.t0) / self.duration, 0.0), 1.0)
        return self.start + (self.goal - self.start) * (u * u * (3.0 - 2.0 * u))


def _baseline_law(tracker: ActuatorTracker, rho_ref_of_t: Callable[[float], NDArray[np.float64]],
                  params: Class2Params) -> Law:
    def law(s: JointSample) -> tuple[Pair, Pair]:
        rho_ref = rho_ref_of_t(s.t)
        f = tracker.forces(rho_ref, s.q[:2], s.qdot[:2], float(s.qdot[2]))
        fk = forward_kinematics(float(rho_ref[0]), float(rho_ref[1]), params)
        return f, (fk.x, fk.y)
    return law


def waypoint_study(law: str = "lqr", *, params: Class2Params = PAPER_PARAMS,
                   offsets: Sequence[tuple[float, float]] = WAYPOINT_OFFSETS,
                   move_time: float = 2.0, settle_time: float = 2.0, rate: float = 100.0,
                   tolerance: float = 5e-5, max_force: float = 5.0, start: tuple[float, float] = (0.7, 0.7),
                   weights: LQRWeights = DEFAULT_WEIGHTS) -> StudyResult:
    """The demo's waypoints (``offsets`` [m] from D at rest at ``start``), each a move of
    ``move_time`` [s] and a hold of ``settle_time`` [s], under ``law`` sampled at ``rate`` [Hz].
    ``tolerance`` [m] is the settling band; ``max_force`` [N] the actuator limit of both laws."""
    if law not in LAWS:
        raise ParameterError(f"law must be one of {', '.join(LAWS)}, got {law!r}")
    rest = forward_kinematics(*start, params)
    loop = _Loop(at_rest_scene(*start, params), rate)
    if law == "lqr":
        ctrl = TrackingController(params, dt=loop.dt, max_force=max_force, weights=weights)
        ctrl.hold(*start, 0.0)
    else:
        tracker = ActuatorTracker(params, max_force=max_force, **BASELINE_GAINS)
    moves: list[MoveResult] = []
    current = np.array(start, dtype=float)
    for dx, dy in offsets:
        target = (rest.x + dx, rest.y + dy)
        s = loop.sample()
        t0 = loop.k * loop.dt
        first = len(loop.trace.t)
        if law == "lqr":
            ctrl.follow(plan_move(s.q, target, params, duration=move_time), t0)
            fn = _lqr_law(ctrl)
        else:
            c = nearest_solution(*target, tuple(current), params)
            goal = np.array([c.rho1, c.rho2])
            fn = _baseline_law(tracker, _Smoothstep(current.copy(), goal, t0, move_time), params)
            current = goal
        loop.run(t0 + move_time + settle_time, fn)
        moves.append(_move_metrics(loop.trace, first, s.end_effector[:2], target, t0 + move_time, tolerance))
    return StudyResult(law, rate, moves, loop.trace)


def _move_metrics(trace: Trace, first: int, start: Pair, target: tuple[float, float], move_end: float,
                  tolerance: float) -> MoveResult:
    t = np.asarray(trace.t[first:])
    D = np.asarray(trace.D[first:])
    err = np.hypot(D[:, 0] - target[0], D[:, 1] - target[1])
    after = t >= move_end - 1e-9
    direction = np.asarray(target) - np.asarray(start)
    length = float(np.hypot(*direction))
    if length > 0:
        beyond = (D[after] - np.asarray(target)) @ (direction / length)
        overshoot = max(0.0, float(np.max(beyond)))
    else:
        overshoot = float(np.max(err[after]))
    return MoveResult(
        target=tuple(map(float, target)), start=tuple(map(float, start)), move_end=move_end,
        settled_error=float(err[-1]), settling_time=_settling(t[after], err[after], tolerance, move_end),
        settling_time_2pc=_settling(t[after], err[after], 0.02 * length, move_end),
        overshoot=overshoot, max_force=float(np.max(np.abs(np.asarray(trace.forces[first:])))),
        max_tracking_error=float(np.max(np.hypot(*(D - np.asarray(trace.desired[first:])).T))))


def _settling(t: NDArray[np.float64], err: NDArray[np.float64], band: float, t0: float) -> float:
    """Time after ``t0`` from which ``err`` stays below ``band`` to the end (inf: it never does)."""
    outside = np.nonzero(err >= band)[0]
    if len(outside) == 0:
        return 0.0
    if outside[-1] == len(err) - 1:
        return math.inf
    return float(t[outside[-1] + 1] - t0)


def circle_study(law: str = "lqr", *, params: Class2Params = PAPER_PARAMS, radius: float = 0.05,
                 period: float = 4.0, ramp: float = 2.0, center: Sequence[float] | None = None, rate: float = 100.0,
                 max_force: float = 5.0, settle_time: float = 1.0,
                 weights: LQRWeights = DEFAULT_WEIGHTS) -> StudyResult:
    """D traces a circle of ``radius`` [m] round ``center`` (default: D at rest at
    rho = (0.7, 0.7)) at one turn per ``period`` [s], from its rightmost point, where the
    mechanism starts at rest: ``ramp`` seconds speeding up, one full turn at constant rate,
    ``ramp`` seconds slowing down (:class:`~tensegrity_core.class2.control.CirclePath`).
    ``extra`` holds the RMS and maximum error of D against the circle's point at each tick
    during the constant-rate turn, and over the whole path [m]."""
    if law not in LAWS:
        raise ParameterError(f"law must be one of {', '.join(LAWS)}, got {law!r}")
    if center is None:
        rest = forward_kinematics(0.7, 0.7, params)
        center = (rest.x, rest.y)
    path = CirclePath((center[0], center[1]), radius, period, ramp=ramp)
    duration = path.duration
    x0, y0 = path.point(np.array([0.0]))[0]
    c = nearest_solution(float(x0), float(y0), (0.7, 0.7), params)
    loop = _Loop(at_rest_scene(c.rho1, c.rho2, params), rate)
    if law == "lqr":
        ctrl = TrackingController(params, dt=loop.dt, max_force=max_force, weights=weights)
        ctrl.hold(c.rho1, c.rho2, 0.0)
        s = loop.sample()
        ctrl.follow(plan_path(path, s.q, params), 0.0)
        fn = _lqr_law(ctrl)
    else:
        tracker = ActuatorTracker(params, max_force=max_force, **BASELINE_GAINS)
        seed = [(c.rho1, c.rho2)]

        def rho_ref(t: float) -> NDArray[np.float64]:
            x, y = path.sample(np.array([min(max(t, 0.0), duration)]))[0][0]
            sol = nearest_solution(float(x), float(y), seed[0], params)
            seed[0] = (sol.rho1, sol.rho2)
            return np.array(seed[0])
        fn = _baseline_law(tracker, rho_ref, params)
    loop.run(duration + settle_time, fn)
    a = loop.trace.arrays()
    t0, t1 = path.steady
    steady = (a["t"] >= t0 - 1e-9) & (a["t"] <= t1 + 1e-9)
    whole = a["t"] <= duration + 1e-9
    err = np.hypot(*(a["D"] - path.sample(a["t"])[0]).T)
    extra = {"rms_error": float(np.sqrt(np.mean(err[steady] ** 2))), "max_error": float(np.max(err[steady])),
             "rms_error_whole": float(np.sqrt(np.mean(err[whole] ** 2))),
             "max_error_whole": float(np.max(err[whole])), "final_error": float(err[-1]),
             "max_force": float(np.max(np.abs(a["forces"])))}
    return StudyResult(law, rate, [], loop.trace, extra)
