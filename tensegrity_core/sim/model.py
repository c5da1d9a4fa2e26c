"""The seam between the simulator and its back ends: a compiled :class:`Model` and a running :class:`State`.

::

    model = compile_scene(load_scene("paper_fold"))   # tensegrity_core.sim.backends
    state = model.initial_state()                     # reset = a new State
    model.set_command(state, [f1, f2])                # zero-order hold from state.t on
    model.advance(state, 0.25)                        # integrate to exactly t = 0.25 s
    state.t, state.y, state.mode, state.commands, state.events
    snapshot = state.copy()

A **model** is what a back end compiles from a scene once: the effects it lists, the drive,
the input laws, the names, the resolved initial state (initial equilibrium, contacts). It is
frozen: nothing is patched onto it and nothing in it changes while a scene runs, so one model
serves any number of states (MuJoCo's ``mjModel``/``mjData`` split; Drake's system/context).

A **state** is what changes: the time, the state vector, the contact mode, the held
commands, the located events ``(t, kind, index)`` and the back end's integrator
(its stepper or path follower, which owns ``t``, ``y`` and ``mode``). Back ends read and
write a state only through the model's methods; everything else reads it.

Every back end implements :class:`Model` (the dynamic ones :class:`DynamicModel`), subclassing
it so that the type checker holds it to the Protocol, and is registered in
:data:`tensegrity_core.sim.backends.BACKENDS` under ``"<kind>/<regime>"``. ``Model[W, S]`` is a
model whose states have integrators of type ``W`` and whose samples (what ``sample`` and
``record`` give, only ``observe`` reads) are of type ``S``.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Generic, Literal, NotRequired, Protocol, Self, TypedDict, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.scene import Scene
from tensegrity_core.sim.stepper import Stepper, Sys

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

class Integrator(Protocol):
    """What advances a :class:`State` of a back end: the stepper of a dynamic
    model, the path follower of a quasi-static one. It owns the time, the state vector and the
    contact mode; ``copy(events)`` gives an independent integrator that logs into ``events``."""

    @property
    def t(self) -> float: ...

    @property
    def y(self) -> NDArray[np.float64]: ...

    @property
    def mode(self) -> frozenset[int]: ...

    def copy(self, events: list[LoggedEvent]) -> Self: ...


#: The integrator type of a model's states.
W = TypeVar("W", bound=Integrator)
#: The sample type of a model (opaque outside it).
S = TypeVar("S")


@dataclass(eq=False)
class State(Generic[W]):
    """The changing part of a simulation (see the module docstring).

    ``commands`` holds the commanded inputs' current values in input order (``nan`` for inputs
    with a law); ``events`` the located events so far; ``work`` the back end's integrator.
    ``t`` [s], ``y`` (the model's state vector, ``model.state_names``) and ``mode`` (the
    actuators held at zero length by the fold limit, 0 for rho1 and 1 for rho2; empty for
    general structures) are the integrator's. Treat all of them as read-only: the model's
    ``set_command`` and ``advance`` change a state.
    """

    commands: tuple[float, ...]
    events: list[LoggedEvent]
    work: W
    #: The model that made the state: only it may run it (:func:`check_owner`).
    owner: object = field(default=None, repr=False)

    @property
    def t(self) -> float:
        return self.work.t

    @property
    def y(self) -> NDArray[np.float64]:
        return self.work.y

    @property
    def mode(self) -> frozenset[int]:
        return self.work.mode

    def copy(self) -> State[W]:
        """An independent snapshot: advancing either leaves the other unchanged. A dynamic
        model's copy restarts its integrator at ``t`` (as after an event), so the two agree to
        the integration tolerance, not bit for bit; a quasi-static copy is exact."""
        events = list(self.events)
        return State(self.commands, events, self.work.copy(events), owner=self.owner)


def check_owner(model: object, state: State[Any]) -> None:
    """Raise :class:`~tensegrity_core.sim.errors.SimulationError` unless ``state`` was made by
    ``model`` (its ``initial_state``/``state_from``, or a copy of one of those). A state holds
    its model's integrator, laws and contact mode: run by another model, even one compiled from
    the same scene, it would silently go on with the first model's equations (Drake refuses a
    context from another system the same way)."""
    if state.owner is not model:
        scene = getattr(getattr(state.owner, "scene", None), "name", None)
        made = f"another model (compiled from scene {scene!r})" if scene else "another model"
        raise SimulationError(f"this state was made by {made}; a state runs only on the model that made it: "
                              "use model.initial_state() (or a copy of a state of this model)")


@dataclass(frozen=True)
class Names:
    """Names of what a model observes: nodes, members (``member_nodes`` (m, 2) node indices;
    ``member_kinds`` per member: general "bar", "string" or "actuator", class-2 "actuator",
    "strut" or "spring", robots "bar" (a rod) or "string" (a cable)), and the rigid bodies
    that move (general structures and robots; in the order of the ``body_*`` observations).
    Robots also name their IMUs (``imu_names``: the body each is fixed to, in the order of
    the ``imu_*`` observations) and their end caps (``cap_names``: the cap's node, in the
    order of ``contact_forces`` and the ``cap_*`` observations)."""

    node_names: tuple[str, ...]
    member_names: tuple[str, ...]
    member_nodes: NDArray[np.int64]
    member_kinds: tuple[str, ...] = ()
    body_names: tuple[str, ...] = ()
    imu_names: tuple[str, ...] = ()
    cap_names: tuple[str, ...] = ()


@dataclass(frozen=True)
class Interface:
    """What a model takes as commands, in the terms a client of the simulator needs.

    ``command``: what an input's value is -- ``"force"``, an actuator force [N], tension
    positive (class-2), or ``"rest_length"``, an actuated member's rest length [m]
    (general structures). ``inputs``: the input names in input order (``actuator_names``);
    ``commanded``: per input, whether it takes commands (its law is "commanded"; the others
    follow the scene's law); ``limits``: per input, the open interval ``(lo, hi)`` a command
    must lie in; ``members``: per input, the index of the member it drives (``-1`` if none);
    ``modes``: robots only, per input its motor's mode (``"rest_length"`` [m],
    ``"reel_speed"`` [m/s] or ``"tension"`` [N], :mod:`tensegrity_core.robot.motor`): what
    that input's value is instead of ``command``, and ``limits`` are in its unit.
    """

    command: Literal["force", "rest_length"]
    inputs: tuple[str, ...]
    commanded: tuple[bool, ...]
    limits: tuple[tuple[float, float], ...]
    members: tuple[int, ...]
    modes: tuple[str, ...] = ()

    @property
    def unit(self) -> str:
        """The unit of an input's value: ``"N"`` or ``"m"``."""
        return "N" if self.command == "force" else "m"

    def range_text(self, i: int) -> str:
        """Input ``i``'s interval as a message shows it, ``"(lo, hi)"`` in ``:g``. A robot
        motor's closed range [lo, hi] is stated one float further out on each side, which ``:g``
        hides except at 0, where that float is subnormal (-4.9e-324): a bound smaller in size
        than the smallest normal float reads 0."""
        lo, hi = (0.0 if abs(b) < sys.float_info.min else b for b in self.limits[i])
        return f"({lo:g}, {hi:g})"


class Observed(TypedDict):
    """One observation of a state (``observe_now``; SI units, forces tension positive).

    ``t`` [s]; ``state`` the state vector (``state_names``); ``q``, ``qdot`` the coordinates
    and rates (class-2 ``rho1, rho2, beta``; general: free node coordinates, body centres and
    rotation vectors from the drawing, and their rates with body angular velocities);
    ``applied_forces`` per input: class-2 the actuator forces [N], general the rest lengths
    [m]; ``contact_forces`` the fold limit's (class-2) [N]; ``nodes`` (n, 3) [m];
    ``member_lengths`` [m] and ``member_forces`` [N] per member; ``end_effector`` (3,) [m];
    energies [J]; ``folded``: an actuator held at zero length.

    Class-2 with inertia adds ``qddot``. General structures add, per member,
    ``member_rest_lengths`` [m], ``member_rates`` (dl/dt [m/s]) and ``member_slack`` (a
    string shorter than its rest length: it carries nothing), and per moving rigid body
    (``Names.body_names``) its frame -- origin at the body's centre (the mean of its nodes),
    axes the world axes in the drawing -- as ``body_positions`` (nb, 3) [m],
    ``body_orientations`` (nb, 4) quaternions ``(x, y, z, w)`` from the world frame,
    ``body_velocities`` (nb, 3) [m/s] of the origin and ``body_angular_velocities`` (nb, 3)
    [rad/s] in the world frame.

    Robots report the members' and bodies' quantities of general structures too (a rod is
    rigid: its rest length is its length, its rate 0, it is never slack; its bodies are the
    rods, then the description's moving bodies) and add ``centre_of_mass`` (3,) [m] and, with the ``sensors`` effect, their sensors'
    readings: ``cable_lengths`` [m] and ``cable_tensions`` [N] of the cables that report them;
    per IMU ``imu_orientation`` (4,) quaternion ``(x, y, z, w)``, ``imu_angular_velocity``
    [rad/s] and ``imu_specific_force`` [m/s^2] in its body's frame; per cap ``cap_contact``
    and ``cap_slipping`` (bool) and ``friction_forces`` (3,) [N].
    """

    t: float
    state: FloatArray
    q: FloatArray
    qdot: FloatArray
    applied_forces: FloatArray
    contact_forces: FloatArray
    nodes: FloatArray
    member_lengths: FloatArray
    member_forces: FloatArray
    end_effector: FloatArray
    potential_energy: float
    kinetic_energy: float
    folded: bool
    qddot: NotRequired[FloatArray]
    member_rest_lengths: NotRequired[FloatArray]
    member_rates: NotRequired[FloatArray]
    member_slack: NotRequired[BoolArray]
    body_positions: NotRequired[FloatArray]
    body_orientations: NotRequired[FloatArray]
    body_velocities: NotRequired[FloatArray]
    body_angular_velocities: NotRequired[FloatArray]
    centre_of_mass: NotRequired[FloatArray]
    cable_lengths: NotRequired[FloatArray]
    cable_tensions: NotRequired[FloatArray]
    imu_orientation: NotRequired[FloatArray]
    imu_angular_velocity: NotRequired[FloatArray]
    imu_specific_force: NotRequired[FloatArray]
    cap_contact: NotRequired[BoolArray]
    cap_slipping: NotRequired[BoolArray]
    friction_forces: NotRequired[FloatArray]


class ObservedArrays(TypedDict):
    """The quantities of :class:`Observed` over N samples (``observe``): each with a leading
    sample axis (``t`` (N,), ``nodes`` (N, n, 3), ``folded`` (N,) bool, ...)."""

    t: FloatArray
    state: FloatArray
    q: FloatArray
    qdot: FloatArray
    applied_forces: FloatArray
    contact_forces: FloatArray
    nodes: FloatArray
    member_lengths: FloatArray
    member_forces: FloatArray
    end_effector: FloatArray
    potential_energy: FloatArray
    kinetic_energy: FloatArray
    folded: BoolArray
    qddot: NotRequired[FloatArray]
    member_rest_lengths: NotRequired[FloatArray]
    member_rates: NotRequired[FloatArray]
    member_slack: NotRequired[BoolArray]
    body_positions: NotRequired[FloatArray]
    body_orientations: NotRequired[FloatArray]
    body_velocities: NotRequired[FloatArray]
    body_angular_velocities: NotRequired[FloatArray]
    centre_of_mass: NotRequired[FloatArray]
    cable_lengths: NotRequired[FloatArray]
    cable_tensions: NotRequired[FloatArray]
    imu_orientation: NotRequired[FloatArray]
    imu_angular_velocity: NotRequired[FloatArray]
    imu_specific_force: NotRequired[FloatArray]
    cap_contact: NotRequired[BoolArray]
    cap_slipping: NotRequired[BoolArray]
    friction_forces: NotRequired[FloatArray]


class JointValues(TypedDict):
    """The cheap part of an observation (``joint_sample``): ``t`` [s], ``q``, ``qdot``,
    ``applied_forces``, ``end_effector`` and ``folded`` as in :class:`Observed`; general
    structures and robots add, per input, the member it drives (``Interface.members``):
    ``actuated_lengths`` [m], ``actuated_rates`` [m/s] and ``actuated_forces`` [N, tension
    positive], as ``member_lengths``, ``member_rates`` and ``member_forces``."""

    t: float
    q: FloatArray
    qdot: FloatArray
    applied_forces: FloatArray
    end_effector: FloatArray
    folded: bool
    actuated_lengths: NotRequired[FloatArray]
    actuated_rates: NotRequired[FloatArray]
    actuated_forces: NotRequired[FloatArray]


def joint_values(obs: Observed, members: Sequence[int] = ()) -> JointValues:
    """The :class:`JointValues` part of an observation; with the inputs' ``members`` (general
    structures and robots) their lengths, rates and forces too."""
    out = JointValues(t=obs["t"], q=obs["q"], qdot=obs["qdot"], applied_forces=obs["applied_forces"],
                      end_effector=obs["end_effector"], folded=obs["folded"])
    driven = list(members)
    if "member_rates" in obs and all(m >= 0 for m in driven):
        out["actuated_lengths"] = obs["member_lengths"][driven]
        out["actuated_rates"] = obs["member_rates"][driven]
        out["actuated_forces"] = obs["member_forces"][driven]
    return out


class Stats(TypedDict, total=False):
    """Integration statistics (``stats``): ``method``; dynamic models ``steps`` (accepted
    integrator steps), ``nfev``, ``restarts``, ``events``; quasi-static ones ``steps`` and
    ``newton_iterations`` (class-2) or ``form_finds`` (general), ``events``; fixed-step back
    ends (robots) their ``step`` [s]; a whole run adds ``wall_time`` [s]."""

    method: str
    steps: int
    nfev: int
    restarts: int
    events: int
    newton_iterations: int
    form_finds: int
    wall_time: float
    step: float



class Frozen:
    """The base of every back end: its attributes are fixed once its ``__init__`` returns.

    Setting or deleting an attribute of a compiled model afterwards raises
    :class:`AttributeError`, and the numpy arrays it holds directly are made read-only, so a
    model shared by many states cannot be changed under them. ``dataclass(frozen=True)`` does
    not fit here: a back end computes its attributes in ``__init__`` from the scene, in an
    order that reads earlier ones; this seals the instance when the outermost ``__init__``
    (the most derived class's) returns.
    """

    __sealed = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        init = cls.__dict__.get("__init__")
        if init is None:
            return

        def sealing_init(self: Frozen, *args: Any, **kw: Any) -> None:
            init(self, *args, **kw)
            if type(self).__init__ is sealing_init:          # the outermost __init__ has run
                for value in vars(self).values():
                    if isinstance(value, np.ndarray):
                        value.flags.writeable = False
                object.__setattr__(self, "_Frozen__sealed", True)

        sealing_init.__doc__, sealing_init.__qualname__ = init.__doc__, init.__qualname__
        cls.__init__ = sealing_init  # type: ignore[method-assign, assignment]

    def __setattr__(self, name: str, value: Any) -> None:
        if self.__sealed:
            raise AttributeError(f"a compiled {type(self).__name__} is frozen: its {name!r} cannot be set "
                                 "(compile a new model from a changed scene instead)")
        object.__setattr__(self, name, value)

    def __delattr__(self, name: str) -> None:
        if self.__sealed:
            raise AttributeError(f"a compiled {type(self).__name__} is frozen: its {name!r} cannot be deleted")
        object.__delattr__(self, name)


class Model(Protocol[W, S]):
    """What every back end implements: a compiled scene (frozen) and the operations on its states.

    ``Backend(scene)`` compiles a checked :class:`~tensegrity_core.sim.scene.Scene`. Attributes:
    ``kind`` ("class2" or "general"), ``quasi_static``, ``scene`` (the scene it was compiled
    from), ``names``, ``state_names`` (of the state vector), ``actuator_names`` (of the
    inputs, in order), ``interface`` (:class:`Interface`: what the inputs take).

    - ``initial_state(t_end=inf)``: a new state at ``t = 0`` (``t_end`` bounds the
      integration: an integrator never steps past it).
    - ``set_command(state, values)``: hold new values of the commanded inputs from ``state.t``
      on (one value per input, in input order; values for inputs with a law are ignored);
      raises :class:`~tensegrity_core.sim.errors.SimulationError` for bad values, leaving the
      state unchanged.
    - ``advance(state, t)``: to exactly time ``t >= state.t`` [s], events located and applied
      on the way.
    - ``sample(state)`` and ``record(state, times, out)``: what an observation needs, at
      ``state.t`` or at increasing ``times`` (advancing the state); only ``observe`` reads them.
    - ``observe(samples)``: the observed quantities of samples as arrays over them
      (:class:`ObservedArrays`); ``observe_now(state)``: the same for ``state.t`` without the
      sample axis (:class:`Observed`), evaluated on floats where that is faster;
      ``joint_sample(state, coordinates=True)``: its cheap part (:class:`JointValues`); with
      ``coordinates=False`` a back end may leave ``q`` and ``qdot`` empty where they cost
      more than the rest (a robot's rotation vectors), for a caller that reads only the
      actuated members' values.
    - ``singular_distance(state)``: ``(name, distance / L)`` of the singular set nearest the
      state's configuration (class-2: ``"lambda1"`` or ``"lambda2"``), or None for a model
      without singular sets.
    - ``stats(state)``: integrator statistics (:class:`Stats`).
    """

    kind: str
    quasi_static: bool
    scene: Scene
    names: Names
    state_names: tuple[str, ...]
    actuator_names: tuple[str, ...]
    interface: Interface

    def __init__(self, scene: Scene) -> None: ...

    def initial_state(self, *, t_end: float = math.inf) -> State[W]: ...

    def set_command(self, state: State[W], values: Iterable[float]) -> None: ...

    def advance(self, state: State[W], t: float) -> None: ...

    def sample(self, state: State[W]) -> S: ...

    def record(self, state: State[W], times: Sequence[float] | NDArray[np.float64], out: list[S]) -> None: ...

    def observe(self, samples: Sequence[S]) -> ObservedArrays: ...

    def observe_now(self, state: State[W]) -> Observed: ...

    def joint_sample(self, state: State[W], *, coordinates: bool = True) -> JointValues: ...

    def singular_distance(self, state: State[W]) -> tuple[str, float] | None: ...

    def stats(self, state: State[W]) -> Stats: ...


class DynamicModel(Model[Stepper[Sys], S], Protocol[Sys, S]):
    """A model with inertia, integrated by a :class:`~tensegrity_core.sim.stepper.Stepper`
    (a state's ``work``: its ``t_integrated`` says how far the integration has gone) of
    :class:`~tensegrity_core.sim.stepper.OdeSystem` s of type ``Sys``.

    - ``state_from(y, t_end=inf)``: a new state at ``t = 0`` from the state vector ``y``
      instead of the scene's initial state (contacts resolved as at compile time);
    - ``equations(state)``: the :class:`~tensegrity_core.sim.stepper.OdeSystem` the
      integrator sees at the state (its right-hand side ``fun(t, y)`` and Jacobian ``jac``).
    """

    method: str

    def state_from(self, y: ArrayLike, *, t_end: float = math.inf) -> State[Stepper[Sys]]: ...

    def equations(self, state: State[Stepper[Sys]]) -> Sys: ...
