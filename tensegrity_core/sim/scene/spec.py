"""What a scene is: the typed, frozen description of a run, checked when it was read.

A :class:`Scene` holds the mechanism (:data:`ModelSpec`), the initial state, one input law
per actuator, the effects it lists (:class:`SceneEffects`, each with its options), the
duration, output rate, integrator and seed. Its parts are ``<Thing>Spec``: what the file asks
for; the objects the simulator builds from them keep the plain names (the kernel's
``Damping``, :class:`~tensegrity_core.sim.noise.SensorNoise`, a back end's integrator).
:mod:`.reader` makes scenes; this module only describes them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, ClassVar, Literal, TypedDict

from tensegrity_core.general.structure import Structure
from tensegrity_core.robot.description import Robot
from tensegrity_core.schema import Reader
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.inputs import InputLaw

if TYPE_CHECKING:
    from tensegrity_core.class2.params import Class2Params

#: Effects a scene may list, in the order the simulator composes them.
EFFECTS = ("inertia", "springs", "damping", "gravity", "loads", "actuator_lag",
           "actuator_compliance", "fold_limit", "sensor_noise", "cables", "motors", "contact", "friction", "sensors")
#: The effects of a robot scene (docs/robots.md): the rods' inertia, the tension-only cables,
#: the cables' motors, gravity, the floor's normal contact and friction, the sensors' readings.
ROBOT_EFFECTS = ("inertia", "cables", "motors", "gravity", "contact", "friction", "sensors")
#: Effects that need inertia, and why (without inertia the model is quasi-static).
NEEDS_INERTIA = {
    "damping": "rates vanish in a quasi-static model, so dampers carry no force",
    "actuator_compliance": "at equilibrium the compliant drive transmits exactly the commanded force",
    "actuator_lag": "a lagging force is a dynamic state; the quasi-static model tracks equilibrium "
                    "for the commanded forces",
}
#: Integration methods: scipy's solve_ivp set, fixed-step RK4 (tensegrity_core.sim.integrators) and "auto".
METHODS = ("auto", "RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA", "RK4")
#: Observed quantities that sensor noise may perturb -> the unit of their noise's sigma
#: (``q`` is the class-2 mechanism's ``[rho1, rho2, beta]``).
NOISE_UNITS = {"q": "m or rad", "qdot": "m/s or rad/s", "applied_forces": "N", "nodes": "m",
               "member_lengths": "m", "member_forces": "N", "end_effector": "m"}
NOISY_QUANTITIES = tuple(NOISE_UNITS)
#: The most memory the output of one run may take (its arrays of 8-byte floats) [bytes].
MAX_OUTPUT_BYTES = 2 * 2**30


# ------------------------------------------------------------------------------ data
@dataclass(frozen=True)
class Class2ModelSpec:
    """The planar class-2 mechanism with parameters ``params``; its inputs are the actuator
    forces (``input_unit``)."""

    params: Class2Params
    kind: ClassVar[Literal["class2"]] = "class2"
    input_unit: ClassVar[str] = "N"


@dataclass(frozen=True)
class GeneralModelSpec:
    """A general structure (bars, strings, actuator members, rigid bodies).

    ``end_effector`` is the index of the node reported as the end effector; ``actuators``
    the member indices of kind ``"actuator"`` (their rest lengths are the inputs)."""

    structure: Structure
    source: str
    end_effector: int
    actuators: tuple[int, ...]
    kind: ClassVar[Literal["general"]] = "general"
    input_unit: ClassVar[str] = "m"


@dataclass(frozen=True)
class RobotModelSpec:
    """A tensegrity robot (:mod:`tensegrity_core.robot`): rods, cables, motors, sensors, floor.

    ``end_effector`` is the index of the node reported as the end effector; ``actuators``
    the indices of the actuated cables in motor order (their motors' rest lengths are the
    inputs)."""

    robot: Robot
    source: str
    end_effector: int
    actuators: tuple[int, ...]
    kind: ClassVar[Literal["robot"]] = "robot"
    input_unit: ClassVar[str] = "m"

    @property
    def structure(self) -> Structure:
        """The robot as the statics see it (:meth:`~tensegrity_core.robot.description.Robot.structure`):
        its node and member names (rods, then cables) name what a robot scene observes."""
        return self.robot.structure()


#: The mechanism a scene simulates.
ModelSpec = Class2ModelSpec | GeneralModelSpec | RobotModelSpec


@dataclass(frozen=True)
class InitialSpec:
    """Initial state. ``kind``: "state" (explicit ``q``, ``qdot``), "equilibrium" (class-2:
    ``q = (rho1, rho2, beta*)`` with ``lengths = (rho1, rho2)``; general: form-found under the
    scene's static effects plus ``preload`` {node index: force [N]}) or "drawn" (general: the
    reference coordinates; a robot raised by ``lift``). Velocities are zero unless ``qdot`` is given."""

    kind: str
    q: tuple[float, ...] | None = None
    qdot: tuple[float, ...] | None = None
    lengths: tuple[float, ...] | None = None
    preload: dict[int, tuple[float, ...]] = field(default_factory=dict)
    lift: float = 0.0         # [m] robots: how far above its drawing (along the floor's normal) it starts


@dataclass(frozen=True)
class DampingSpec:
    """Class-2: the springs' dampers ``c1..c4`` of the parameters. General: an axial damper
    on every taut member, ``c`` [N s/m] or stiffness-proportional ``beta`` [s] (``c_i = beta EA_i / l0_i``)."""

    c: float | None = None
    beta: float | None = None


@dataclass(frozen=True)
class GravitySpec:
    vector: tuple[float, ...]             # [m/s^2], 3 components


@dataclass(frozen=True)
class LoadsSpec:
    forces: dict[int, tuple[float, ...]]  # node index -> (fx, fy, fz) [N], dead loads


@dataclass(frozen=True)
class ActuatorLagSpec:
    tau: float                # [s]


@dataclass(frozen=True)
class ActuatorComplianceSpec:
    stiffness: float          # [N/m]
    drive_damping: float      # [N s/m]


@dataclass(frozen=True)
class FoldLimitSpec:
    restitution: float = 0.0
    rest_velocity: float = 1e-6   # [m/s]: rebounds slower than this stick


@dataclass(frozen=True)
class SensorNoiseSpec:
    sigmas: dict[str, float]  # quantity -> standard deviation (units of the quantity)


@dataclass(frozen=True)
class MotorsSpec:
    """Robots: the cables' motors (first-order lag, slew limit, tension limit); each value
    given here replaces every motor's: ``tau`` [s], ``max_speed`` [m/s], ``max_tension`` [N]
    (None: each motor's own); ``modes``: ``(cable name, mode)`` pairs that replace those
    motors' modes (:data:`tensegrity_core.robot.motor.MODES`' values)."""

    tau: float | None = None
    max_speed: float | None = None
    max_tension: float | None = None
    modes: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True)
class ContactSpec:
    """Robots: the floor's normal contact, stiffness [N/m] and Hunt-Crossley dissipation [s/m]."""

    stiffness: float
    dissipation: float


@dataclass(frozen=True)
class FrictionSpec:
    """Robots: the floor's stick-slip friction: coefficients (``mu_kinetic <= mu_static``),
    the anchor's ``tangential_stiffness`` [N/m] and ``tangential_damping`` [N s/m], the
    caps' ``rolling_friction`` and ``torsional_friction`` lever arms [m]."""

    mu_static: float
    mu_kinetic: float
    tangential_stiffness: float
    tangential_damping: float
    rolling_friction: float = 0.0
    torsional_friction: float = 0.0


@dataclass(frozen=True)
class FlagSpec:
    """An effect without options (inertia, springs, cables, sensors)."""


class SceneEffects(TypedDict, total=False):
    """The effects a scene lists, each with its options (a plain dict in :data:`EFFECTS` order)."""

    inertia: FlagSpec
    springs: FlagSpec
    damping: DampingSpec
    gravity: GravitySpec
    loads: LoadsSpec
    actuator_lag: ActuatorLagSpec
    actuator_compliance: ActuatorComplianceSpec
    fold_limit: FoldLimitSpec
    sensor_noise: SensorNoiseSpec
    cables: FlagSpec
    motors: MotorsSpec
    contact: ContactSpec
    friction: FrictionSpec
    sensors: FlagSpec


#: The options of one effect.
EffectSpec = (FlagSpec | DampingSpec | GravitySpec | LoadsSpec | ActuatorLagSpec | ActuatorComplianceSpec | FoldLimitSpec
              | SensorNoiseSpec | MotorsSpec | ContactSpec | FrictionSpec)


@dataclass(frozen=True)
class RollSpec:
    """Robots: the closed-loop rolling gait (:class:`~tensegrity_core.robot.roll_control.RollController`)
    run by the scene: roll ``faces`` (>= 1) new faces towards ``heading`` (a nonzero
    direction (x, y) on the floor, world frame), the controller sampled at ``rate`` [Hz]."""

    faces: int
    heading: tuple[float, float]
    rate: float = 50.0


@dataclass(frozen=True)
class IntegratorSpec:
    method: str = "auto"
    rtol: float = 1e-8
    atol: float = 1e-10
    max_step: float = math.inf


@dataclass(frozen=True)
class Scene:
    """A checked scene. ``effects`` maps each listed effect name to its options; ``inputs``
    maps each actuator (class-2: ``"f1"``, ``"f2"``; general: actuator member names) to its law;
    ``control`` (robots) the closed-loop gait that commands the motors, or None."""

    name: str
    model: ModelSpec
    initial: InitialSpec
    inputs: dict[str, InputLaw]
    effects: SceneEffects
    duration: float
    output_rate: float = 100.0
    integrator: IntegratorSpec = IntegratorSpec()
    seed: int = 0
    description: str = ""
    control: RollSpec | None = None
    source: str | None = None
    data: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def quasi_static(self) -> bool:
        """True when the scene has no inertia: the configuration tracks equilibrium."""
        return "inertia" not in self.effects

    def has(self, effect: str) -> bool:
        return effect in self.effects

    def with_duration(self, duration: float) -> Scene:
        """A copy that runs for ``duration`` [s] (checked like the scene's own)."""
        reader = Reader(SceneError)
        duration = reader.value_number(duration, ("duration",), None, None, unit="s", lo=0.0, lo_open=True)
        reason = output_size_reason(duration, self.output_rate, self.model)
        if reason:
            raise SceneError(reason, key=("duration",))
        return replace(self, duration=duration)


def output_size_reason(duration: float, rate: float, model: ModelSpec) -> str | None:
    """Why ``duration`` [s] at ``rate`` [Hz] is too much output for ``model``, or None: the
    run's arrays (``duration * rate + 2`` samples of every recorded value) must fit in
    :data:`MAX_OUTPUT_BYTES`; they are allocated as the run goes, so the bound is checked
    before it starts."""
    samples = math.floor(duration * rate) + 2
    values = values_per_sample(model)
    size = samples * values * 8
    if size <= MAX_OUTPUT_BYTES:
        return None
    return (f"duration x output.rate = {duration:g} s x {rate:g} Hz gives {samples:.3g} samples of "
            f"{values} values, {size:.3g} bytes, more than the {MAX_OUTPUT_BYTES / 2**30:g} GiB a run's "
            f"output may take; shorten the duration or lower output.rate")


def values_per_sample(model: ModelSpec) -> int:
    """Floats recorded per output sample (an upper bound): states, coordinates, rates,
    inputs, member forces and lengths, node positions, energies."""
    if model.kind == "class2":
        return 64
    if model.kind == "robot":
        r = model.robot
        bodies = len(r.rods) + len(r.bodies)
        caps = 2 * len(r.rods)
        return int(4 * (6 * bodies + 3 * r.n_nodes) + 2 * (len(r.rods) + len(r.cables)) + 6 * r.n_nodes
                   + 3 * len(r.cables) + 12 * caps + 16 * bodies + 16)
    s = model.structure
    return int(4 * s.layout.n_dof + 2 * s.n_members + 3 * s.n_nodes + len(model.actuators) + 16)
