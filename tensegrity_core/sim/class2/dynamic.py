"""The class-2 back end with inertia: the kernel's equations of motion, integrated by a stepper.

:class:`Class2Dynamic` compiles a class-2 scene that lists ``inertia`` into a frozen model:
the :class:`~tensegrity_core.sim.class2.plant.Class2Plant` (listed effects, drive, fold
limit), the input laws, the commands that hold the initial state at rest, the initial state
with its contacts resolved, and a :class:`~tensegrity_core.sim.class2.observe.Class2Observer`.
A state's integrator is a :class:`~tensegrity_core.sim.stepper.Stepper` integrating the
plant's :class:`~tensegrity_core.sim.class2.plant.Class2System` of the current contact mode and commands.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim.class2.observe import Class2Observer
from tensegrity_core.sim.class2.plant import Class2Plant, Class2System
from tensegrity_core.sim.class2.setup import (
    NAMES,
    class2_interface,
    class2_params,
    force_effects,
    initial_configuration,
    singular_distance,
    static_force,
)
from tensegrity_core.sim.commands import changed, check_command, compile_inputs
from tensegrity_core.sim.inputs import held
from tensegrity_core.sim.model import (
    DynamicModel,
    Frozen,
    JointValues,
    Observed,
    ObservedArrays,
    State,
    Stats,
    check_owner,
)
from tensegrity_core.sim.scene import Scene
from tensegrity_core.sim.stepper import Stepper

FloatArray = NDArray[np.float64]
#: What an observation needs of one state: ``(t [s], y, contact mode bits, transmitted forces (T1, T2) [N])``.
Class2Sample = tuple[float, FloatArray, int, tuple[float, float]]


class Class2Dynamic(Frozen, DynamicModel[Class2System, Class2Sample]):
    """Back end ``class2/dynamic``: the class-2 equations of motion with the scene's effects
    (implements :class:`~tensegrity_core.sim.model.DynamicModel`)."""

    kind = "class2"
    quasi_static = False
    names = NAMES

    def __init__(self, scene: Scene):
        params = class2_params(scene)
        self.scene = scene
        self.params = params
        effects = force_effects(scene)
        q0, qd0 = initial_configuration(scene, effects)
        self.laws, self.actuator_names, self.initial_commands = compile_inputs(
            scene.inputs, static_force(effects, params.L, q0)[:2])
        self.interface = class2_interface(self.actuator_names, self.laws)
        self.plant = Class2Plant(scene, effects)
        self.state_names = self.plant.state_names
        self.observer = Class2Observer(scene, effects, inertia=True)
        method = scene.integrator.method
        if method == "auto":
            method = "Radau" if "actuator_compliance" in scene.effects else "DOP853"
        self.method = method
        laws0 = held(self.laws, self.initial_commands)
        y0 = np.concatenate([q0, qd0, self.plant.drive.initial_states(0.0, q0, laws0)])
        self.plant.check_state(y0)
        self.y0, self.mode0 = self.plant.system((), laws0).resolve_contacts(0.0, y0)

    # -- states ---------------------------------------------------------------------------------
    def initial_state(self, *, t_end: float = math.inf) -> State[Stepper[Class2System]]:
        """The scene's initial state at ``t = 0`` (resolved once, at compile time)."""
        return self._state(self.y0, self.mode0, t_end)

    def state_from(self, y: ArrayLike, *, t_end: float = math.inf) -> State[Stepper[Class2System]]:
        """A state at ``t = 0`` from the state vector ``y`` (``state_names``), its contacts resolved."""
        y0 = np.array(y, dtype=float).ravel()
        self.plant.check_state(y0)
        y0, mode = self.plant.system((), held(self.laws, self.initial_commands)).resolve_contacts(0.0, y0)
        return self._state(y0, mode, t_end)

    def _state(self, y: FloatArray, mode: frozenset[int], t_end: float) -> State[Stepper[Class2System]]:
        events: list[LoggedEvent] = []
        s = self.scene.integrator
        system = self.plant.system(mode, held(self.laws, self.initial_commands))
        stepper = Stepper(system, 0.0, y, method=self.method, rtol=s.rtol, atol=s.atol, max_step=s.max_step,
                          t_end=t_end, log=events)
        return State(self.initial_commands, events, stepper, owner=self)

    def equations(self, state: State[Stepper[Class2System]]) -> Class2System:
        """The system (contact mode, commands) the integrator sees at ``state``."""
        check_owner(self, state)
        return state.work.system

    # -- running ------------------------------------------------------------------------------
    def set_command(self, state: State[Stepper[Class2System]], values: Iterable[float]) -> None:
        check_owner(self, state)
        commands = check_command(values, self.laws, self.actuator_names)
        if not changed(state.commands, commands):
            return
        state.commands = commands
        st = state.work
        st.change_system(st.system.with_laws(held(self.laws, commands)))

    def advance(self, state: State[Stepper[Class2System]], t: float) -> None:
        check_owner(self, state)
        state.work.advance(t)

    def sample(self, state: State[Stepper[Class2System]]) -> Class2Sample:
        """What an observation needs at ``state.t``: ``(t, y, mode bits, T (2,))``."""
        st = state.work
        y = st.y
        return st.t, y.copy(), st.system.bits, st.system.drive.forces(st.t, y.tolist())

    def record(self, state: State[Stepper[Class2System]], times: Sequence[float] | FloatArray,
               out: list[Class2Sample]) -> None:
        """Append samples at increasing ``times`` to ``out``."""
        check_owner(self, state)
        states: list[tuple[float, FloatArray, Class2System]] = []
        try:
            state.work.record(times, states)
        finally:
            out.extend((t, y, seg.bits, seg.drive.forces(t, y.tolist())) for t, y, seg in states)

    def observe(self, samples: Sequence[Class2Sample]) -> ObservedArrays:
        """Observed quantities of recorded samples ``[(t, y, mode bits, T), ...]`` (arrays)."""
        return self.observer.many([s[0] for s in samples], [s[1] for s in samples], [s[2] for s in samples],
                                  [s[3] for s in samples])

    def observe_now(self, state: State[Stepper[Class2System]]) -> Observed:
        """The observation at ``state.t`` (one sample, on floats)."""
        check_owner(self, state)
        return self.observer.one(*self.sample(state))

    def joint_sample(self, state: State[Stepper[Class2System]], *, coordinates: bool = True) -> JointValues:
        """Joint positions, rates, transmitted forces, node D and the fold flag at ``state.t``."""
        check_owner(self, state)
        t, y, bits, T = self.sample(state)
        L = self.params.L
        ee = np.array([y[0] + L * math.cos(y[2]), L * math.sin(y[2]), 0.0])
        return JointValues(t=float(t), q=y[:3], qdot=y[3:6], applied_forces=np.asarray(T, dtype=float),
                           end_effector=ee, folded=bool(bits))

    def singular_distance(self, state: State[Stepper[Class2System]]) -> tuple[str, float]:
        return singular_distance(self.params, state.y)

    def stats(self, state: State[Stepper[Class2System]]) -> Stats:
        st = state.work
        return Stats(method=self.method, steps=st.n_steps, nfev=st.nfev, restarts=st.n_restarts - 1,
                     events=st.n_events)
