"""The scene-driven simulator: the stepping API the ROS node uses, and whole runs.

::

    sim = Simulator(load_scene("paper_fold"))
    sim.set_command([f1, f2])      # commanded inputs (zero-order hold) [N]
    sim.advance(t)                 # integrate up to t [s]
    obs = sim.observe()            # Observation at sim.t (sensor noise applied if listed)
    sim.reset()                    # a new State at t = 0 (the model is not compiled again)
    traj = simulate("paper_fold")  # the whole scene -> Trajectory

A :class:`Simulator` is a convenience over a compiled :class:`~tensegrity_core.sim.model.Model`
(``sim.model``) and one :class:`~tensegrity_core.sim.model.State` (``sim.state``), plus the
scene's sensor noise on what it observes. The back end is chosen by the scene (see
:mod:`tensegrity_core.sim.backends`): class-2 or general structure, with inertia (equations
of motion) or without (quasi-static: the configuration tracks equilibrium).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim.backends import compile_scene
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.invariants import violations
from tensegrity_core.sim.model import Interface, Model, Observed, State, Stats
from tensegrity_core.sim.noise import SensorNoise
from tensegrity_core.sim.scene import SceneSource, load_scene
from tensegrity_core.sim.stiffness_check import warn_if_stiff
from tensegrity_core.sim.trajectory import Trajectory

if TYPE_CHECKING:
    from typing_extensions import TypeIs

FloatArray = NDArray[np.float64]


@dataclass
class Observation:
    """The observed state at time ``t`` [s] (SI units; forces tension-positive).

    ``q, qdot``: class-2 ``(rho1, rho2, beta)`` and rates; general structures the minimal
    coordinates (free node coordinates, body centres, body rotation vectors) and their rates
    (body angular velocities in the world frame). ``applied_forces``: class-2 the actuator
    forces acting on the mechanism [N]; general the actuators' rest lengths [m].
    ``nodes`` (n, 3) [m]; ``member_nodes`` (m, 2) node indices; ``member_forces`` [N];
    ``end_effector`` (3,) [m] (class-2: node D); energies [J]; ``folded``: an actuator is
    held at zero length by the fold limit; ``contact_forces`` the fold limit's contact
    forces [N] (compressive, >= 0). ``state`` is the model's full state vector.

    General structures also report, per member, ``member_rest_lengths`` [m],
    ``member_rates`` (dl/dt [m/s]) and ``member_slack`` (a string shorter than its rest
    length), and per moving rigid body (``body_names``) its frame's ``body_positions`` (nb,
    3) [m], ``body_orientations`` (nb, 4) quaternions ``(x, y, z, w)``, ``body_velocities``
    [m/s] and ``body_angular_velocities`` [rad/s] in the world frame (see
    :class:`~tensegrity_core.sim.model.Observed`); empty for the class-2 mechanism.

    Robots with the ``sensors`` effect also report, per IMU (``imu_names``: the body it is
    fixed to), ``imu_orientation`` (4,) ``(x, y, z, w)``, ``imu_angular_velocity`` [rad/s]
    and ``imu_specific_force`` [m/s^2] in its body's frame, and per end cap (``cap_names``)
    ``cap_contact``, ``cap_slipping`` and ``friction_forces`` (3,) [N]; the caps' normal
    forces [N] are ``contact_forces``.
    """

    t: float
    q: FloatArray
    qdot: FloatArray
    applied_forces: FloatArray
    node_names: tuple[str, ...]
    nodes: FloatArray
    member_names: tuple[str, ...]
    member_nodes: NDArray[np.int64]
    member_lengths: FloatArray
    member_forces: FloatArray
    end_effector: FloatArray
    potential_energy: float
    kinetic_energy: float
    folded: bool
    contact_forces: FloatArray = field(default_factory=lambda: np.zeros(0))
    state: FloatArray = field(default_factory=lambda: np.zeros(0))
    member_kinds: tuple[str, ...] = ()
    member_rest_lengths: FloatArray = field(default_factory=lambda: np.zeros(0))
    member_rates: FloatArray = field(default_factory=lambda: np.zeros(0))
    member_slack: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    body_names: tuple[str, ...] = ()
    body_positions: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    body_orientations: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))
    body_velocities: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    body_angular_velocities: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    imu_names: tuple[str, ...] = ()
    imu_orientation: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))
    imu_angular_velocity: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    imu_specific_force: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    cap_names: tuple[str, ...] = ()
    cap_contact: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    cap_slipping: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    friction_forces: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))


@dataclass
class JointSample:
    """The cheap part of an observation, for high-rate publishing (cheap for the class-2
    mechanism and robots; general structures evaluate an observation).

    ``q = (rho1, rho2, beta)`` [m, m, rad], ``qdot`` their rates, ``applied_forces`` the
    actuator forces [N] (tension positive), ``end_effector`` node D (3,) [m], ``folded`` an
    actuator held at zero length. Sensor noise, when the scene lists it, is added to the
    same quantities as in :meth:`Simulator.observe`. General structures and robots also give,
    per input, the length [m], rate [m/s] and force [N] of the member it drives
    (``actuated_lengths``, ``actuated_rates``, ``actuated_forces``; empty for the class-2
    mechanism; sensor noise is not added to them).
    """

    t: float
    q: FloatArray
    qdot: FloatArray
    applied_forces: FloatArray
    end_effector: FloatArray
    folded: bool
    actuated_lengths: FloatArray = field(default_factory=lambda: np.zeros(0))
    actuated_rates: FloatArray = field(default_factory=lambda: np.zeros(0))
    actuated_forces: FloatArray = field(default_factory=lambda: np.zeros(0))


class Simulator:
    """A running simulation of one scene: a compiled model and its current state.

    ``scene`` is anything :func:`~tensegrity_core.sim.scene.load_scene` reads, or a compiled
    :class:`~tensegrity_core.sim.model.Model`. ``t_end`` bounds the integration (default:
    open-ended, for the ROS node); the stepping integrator never steps past it. ``model`` and
    ``scene`` are fixed; ``state`` is the current :class:`~tensegrity_core.sim.model.State`
    (assign another of the same model to continue from it).
    """

    def __init__(self, scene: SceneSource | Model[Any, Any], *, t_end: float = math.inf):
        self.model: Model[Any, Any] = scene if _is_model(scene) else compile_scene(load_scene(scene))
        self.scene = self.model.scene
        if self.scene.control is not None:
            # its motors answer its controller, not set_command: stepping it here would
            # silently drop the controller
            raise SimulationError(
                f"scene {self.scene.name!r} rolls under its closed-loop gait (control.roll), which "
                f"`tensegrity simulate {self.scene.name}` runs; to step it or drive it over ROS, run its "
                "robot's scene without `control` and the gait as a client (`tensegrity gait six_bar roll "
                "--faces N`, docs/ros.md)")
        self.kind = self.model.kind
        self.quasi_static = self.model.quasi_static
        self.interface: Interface = self.model.interface
        self.t_end = t_end
        self.state: State[Any] = self.model.initial_state(t_end=t_end)
        noise = self.scene.effects.get("sensor_noise")
        # stateless: the noise of an observation depends on its time only (sim/noise.py)
        self._noise = SensorNoise(noise.sigmas, self.scene.seed) if noise is not None else None

    def reset(self) -> None:
        """Back to the scene's initial state at ``t = 0`` (a new state; sensor noise is a
        function of the observation time, so it replays too): the same as a new simulator of
        the scene, without compiling it."""
        self.state = self.model.initial_state(t_end=self.t_end)

    @property
    def t(self) -> float:
        """Current simulation time [s]."""
        return self.state.t

    @property
    def command(self) -> list[float]:
        """Current values of the commanded inputs (``nan`` for inputs with a law)."""
        return list(self.state.commands)

    @property
    def events(self) -> list[LoggedEvent]:
        """``(t, kind, index)`` of every event so far (fold, release, limit, ...)."""
        return list(self.state.events)

    def set_command(self, values: Iterable[float]) -> None:
        """Set the commanded inputs (one value per actuator, in the scene's input order; values
        for inputs with a law are ignored). Zero-order hold from the current time on."""
        self.model.set_command(self.state, values)

    def advance(self, t_target: float) -> None:
        """Integrate up to ``t_target`` [s] (>= ``t``)."""
        if not (isinstance(t_target, (int, float)) and math.isfinite(t_target)):
            raise SimulationError(f"advance: t_target must be a finite number of seconds, got {t_target!r}")
        self.model.advance(self.state, float(t_target))

    def observe(self) -> Observation:
        """The state at ``t`` (with sensor noise if the scene lists it). Class-2 scenes evaluate
        the one sample on floats (tens of microseconds); the result equals the vectorised
        observations of :func:`simulate` to rounding."""
        obs = observation(self.model, self.model.observe_now(self.state))
        if self._noise is not None:
            self._noise.perturb(obs)
        return obs

    def joint_sample(self, *, coordinates: bool = True) -> JointSample:
        """Joint positions, rates, applied forces and end-effector at ``t``, without member
        forces or energies: ~2 us where :meth:`observe` takes ~30 us (dynamic class-2 scenes;
        other scenes evaluate an observation). ``coordinates=False``: for a caller that reads
        only the actuated members' values, ``q`` and ``qdot`` may be empty (robots: the
        rods' rotation vectors are not computed)."""
        d = self.model.joint_sample(self.state, coordinates=coordinates)
        applied = np.asarray(d["applied_forces"], dtype=float)
        if "actuated_lengths" in d:
            sample = JointSample(d["t"], d["q"], d["qdot"], applied, d["end_effector"], d["folded"],
                                 d["actuated_lengths"], d["actuated_rates"], d["actuated_forces"])
        else:
            sample = JointSample(d["t"], d["q"], d["qdot"], applied, d["end_effector"], d["folded"])
        if self._noise is not None:
            self._noise.perturb(sample)
        return sample

    def singular_distance(self) -> tuple[str, float] | None:
        """``(name, distance / L)`` of the singular set nearest the current configuration
        (class-2), or None for a model without singular sets."""
        return self.model.singular_distance(self.state)

    def stats(self) -> Stats:
        """Integrator statistics (steps, function evaluations, restarts, events)."""
        return self.model.stats(self.state)


def _is_model(value: object) -> TypeIs[Model[Any, Any]]:
    return hasattr(value, "initial_state") and hasattr(value, "observe_now")


def observation(model: Model[Any, Any], data: Observed) -> Observation:
    """The :class:`Observation` of one sample's values (``model.observe_now``)."""
    names = model.names
    obs = Observation(
        t=float(data["t"]), q=data["q"], qdot=data["qdot"], applied_forces=data["applied_forces"],
        node_names=names.node_names, nodes=data["nodes"], member_names=names.member_names,
        member_nodes=names.member_nodes, member_lengths=data["member_lengths"],
        member_forces=data["member_forces"], end_effector=data["end_effector"],
        potential_energy=float(data["potential_energy"]), kinetic_energy=float(data["kinetic_energy"]),
        folded=bool(data["folded"]), contact_forces=data["contact_forces"], state=data["state"],
        member_kinds=names.member_kinds, body_names=names.body_names)
    if "member_rest_lengths" in data:
        obs.member_rest_lengths = data["member_rest_lengths"]
        obs.member_rates = data["member_rates"]
        obs.member_slack = data["member_slack"]
    if "body_positions" in data:
        obs.body_positions = data["body_positions"]
        obs.body_orientations = data["body_orientations"]
        obs.body_velocities = data["body_velocities"]
        obs.body_angular_velocities = data["body_angular_velocities"]
    if "imu_orientation" in data:
        obs.imu_names, obs.cap_names = names.imu_names, names.cap_names
        obs.imu_orientation = data["imu_orientation"]
        obs.imu_angular_velocity = data["imu_angular_velocity"]
        obs.imu_specific_force = data["imu_specific_force"]
        obs.cap_contact = data["cap_contact"]
        obs.cap_slipping = data["cap_slipping"]
        obs.friction_forces = data["friction_forces"]
    return obs


def simulate(scene: SceneSource, *, duration: float | None = None,
             progress: Callable[[float, float], object] | None = None,
             stop: Callable[[], bool] | None = None) -> Trajectory:
    """Run a whole scene and return its :class:`Trajectory` at the scene's output rate (and at
    the end time when that is not on the output grid).

    ``duration`` overrides the scene's; ``progress(t, duration)`` is called as the run goes
    (simulated time ``t`` reached [s]; a few times a second on a slow run, about every 2 % of
    the samples on a fast one). Commanded inputs hold their initial value, unless the scene
    has ``control`` (robots: the closed-loop rolling gait commands them through a
    :class:`~tensegrity_core.sim.control_loop.ControlLoop`). Before the run, a
    :class:`~tensegrity_core.sim.stiffness_check.StiffnessWarning` says when the scene's
    explicit method does not fit its stiffness; after it, ``Trajectory.violations`` lists the
    invariants the run broke (:mod:`tensegrity_core.sim.invariants`). ``stop()`` is asked
    as often: once it is true the run ends there and the trajectory holds the samples
    computed so far (``success`` False, message ``"interrupted at t = ... s"``), as a run
    that stops early does.
    """
    scene = load_scene(scene)
    if duration is not None:
        scene = scene.with_duration(duration)
    wall0 = time.perf_counter()
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    warn_if_stiff(model, state, scene.duration)
    n = int(math.floor(scene.duration * scene.output_rate * (1 + 1e-12))) + 1
    times = np.arange(n) / scene.output_rate
    if times[-1] < scene.duration * (1 - 1e-12):         # the run always ends at its duration
        times = np.append(times, scene.duration)
        n += 1
    times[-1] = scene.duration      # a grid point within rounding of it (1.21 for 1.2099999999999997 s)
    record = _recorder(model, state)
    samples: list[Any] = []
    error: str = ""
    largest = max(1, n // 50)       # progress at least every 2 % of the samples, if watched
    chunk = 1 if progress is not None or stop is not None else n
    start = 0
    while start < n:
        wall = time.perf_counter()
        try:
            record(times[start:start + chunk], samples)
        except SimulationError as err:
            error = str(err)
            break
        start = min(start + chunk, n)
        if progress is not None:
            progress(float(times[start - 1]), scene.duration)
        if progress is not None or stop is not None:
            # chunks of about a tenth of a second of wall time, up to 2 % of the samples
            took = time.perf_counter() - wall
            chunk = max(1, chunk // 2) if took > 0.2 else min(largest, 2 * chunk) if took < 0.05 else chunk
        if stop is not None and stop() and start < n:
            error = f"interrupted at t = {float(times[start - 1]):.6g} s"
            break
    data = model.observe(samples)
    noise = scene.effects.get("sensor_noise")
    measurements = SensorNoise(noise.sigmas, scene.seed).perturb_arrays(data) if noise is not None else {}
    stats = model.stats(state)
    stats["wall_time"] = time.perf_counter() - wall0
    broken = violations(data, state.events, fold_limit="fold_limit" in scene.effects)
    return Trajectory.from_observations(scene, data, model.names, list(state.events), measurements, stats,
                                        error=error, state_names=model.state_names, violations=broken)


def _recorder(model: Model[Any, Any], state: State[Any]) -> Callable[[FloatArray, list[Any]], None]:
    """What records the samples of a run of ``model`` from ``state``: the model's own stepping,
    or with the scene's ``control`` (robots) the closed-loop gait sampled at its rate."""
    control = model.scene.control
    if control is None:
        return lambda times, samples: model.record(state, times, samples)
    from tensegrity_core.robot.roll_control import RollController
    from tensegrity_core.sim.control_loop import ControlledModel, ControlLoop
    from tensegrity_core.sim.scene.spec import RobotModelSpec

    robot = model.scene.model
    assert isinstance(robot, RobotModelSpec)        # the schema takes 'control' for robot scenes only
    controller = RollController(robot.robot, control.faces, heading=control.heading)
    return ControlLoop(cast(ControlledModel, model), state, controller, rate=control.rate).record   # a robot's
