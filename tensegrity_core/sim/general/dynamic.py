"""The general-structure back end with inertia: nodal and rigid-body dynamics, integrated by a stepper.

:class:`GeneralDynamic` compiles a general scene that lists ``inertia`` into a frozen model:
the :class:`~tensegrity_core.sim.general.model.GeneralSystem` of the initial equilibrium's
rotation charts under the initial commands, the input laws and the initial coordinates. A
state's integrator is a :class:`~tensegrity_core.sim.stepper.Stepper`; its system is the
general model of the current charts and commands (each sample keeps the model it was taken
under, so an observation sees the charts of its own time).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim.commands import changed, check_command
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.general.model import GeneralSystem, NodalMasses
from tensegrity_core.sim.general.setup import (
    OBSERVED,
    GeneralBackEnd,
    coordinates,
    finish_observations,
    first_observation,
    general_model,
    initial_configuration,
    member_damping,
    rest_lengths_function,
    scene_gravity,
    scene_loads,
)
from tensegrity_core.sim.inputs import held
from tensegrity_core.sim.model import (
    DynamicModel,
    JointValues,
    Observed,
    ObservedArrays,
    State,
    Stats,
    check_owner,
    joint_values,
)
from tensegrity_core.sim.scene import Scene
from tensegrity_core.sim.stepper import Stepper

FloatArray = NDArray[np.float64]
#: What an observation needs of one state: ``(t [s], y, the equations of its charts and commands)``.
GeneralSample = tuple[float, FloatArray, GeneralSystem]


class GeneralDynamic(GeneralBackEnd, DynamicModel[GeneralSystem, GeneralSample]):
    """Back end ``general/dynamic``: nodal / rigid-body dynamics of a general structure
    (implements :class:`~tensegrity_core.sim.model.DynamicModel`)."""

    quasi_static = False

    def __init__(self, scene: Scene):
        super().__init__(scene)
        s = self.structure
        config = initial_configuration(scene)
        self.x0 = coordinates(config)
        laws0 = held(self.laws, self.initial_commands)
        self.plant = GeneralSystem(s, masses=NodalMasses(s), damping=member_damping(scene),
                                  gravity=scene_gravity(scene), loads=scene_loads(scene),
                                  rest_lengths_of=rest_lengths_function(scene, laws0), laws=laws0,
                                  actuators=general_model(scene).actuators, R_ref=config.rotations)
        self.state_names = self.plant.state_names
        method = scene.integrator.method
        # auto: DOP853, on the front of the general scenes' work-precision study (docs/design/performance.md)
        self.method = "DOP853" if method == "auto" else method

    # -- states ---------------------------------------------------------------------------------
    def initial_state(self, *, t_end: float = math.inf) -> State[Stepper[GeneralSystem]]:
        """The initial equilibrium at rest (found once, at compile time)."""
        return self._state(np.concatenate([self.x0, np.zeros(len(self.x0))]), t_end)

    def state_from(self, y: ArrayLike, *, t_end: float = math.inf) -> State[Stepper[GeneralSystem]]:
        """A state at ``t = 0`` from the state vector ``y`` (``state_names``: coordinates in the
        initial rotation charts, then rates)."""
        y = np.array(y, dtype=float).ravel()
        if len(y) != 2 * self.plant.n or not np.all(np.isfinite(y)):
            raise SimulationError(f"a state of this model is {2 * self.plant.n} finite numbers, got {y!r}")
        return self._state(y, t_end)

    def _state(self, y: FloatArray, t_end: float) -> State[Stepper[GeneralSystem]]:
        events: list[LoggedEvent] = []
        s = self.scene.integrator
        start = self.plant.resume(0.0, y)          # the strings' slack set at the start
        stepper = Stepper(start.system, 0.0, start.y, method=self.method, rtol=s.rtol, atol=s.atol,
                          max_step=s.max_step, t_end=t_end, log=events)
        return State(self.initial_commands, events, stepper, owner=self)

    def equations(self, state: State[Stepper[GeneralSystem]]) -> GeneralSystem:
        """The model (charts, commands) the integrator sees at ``state``."""
        check_owner(self, state)
        return state.work.system

    # -- running ------------------------------------------------------------------------------
    def set_command(self, state: State[Stepper[GeneralSystem]], values: Iterable[float]) -> None:
        check_owner(self, state)
        commands = check_command(values, self.laws, self.actuator_names, positive=True)
        if not changed(state.commands, commands):
            return
        state.commands = commands
        laws = held(self.laws, commands)
        st = state.work
        st.change_system(st.system.with_inputs(rest_lengths_function(self.scene, laws), laws))

    def advance(self, state: State[Stepper[GeneralSystem]], t: float) -> None:
        check_owner(self, state)
        state.work.advance(t)

    def sample(self, state: State[Stepper[GeneralSystem]]) -> GeneralSample:
        """``(t, y, model)``: the model keeps this sample's rotation charts and rest lengths."""
        st = state.work
        return st.t, st.y.copy(), st.system

    def record(self, state: State[Stepper[GeneralSystem]], times: Sequence[float] | FloatArray,
               out: list[GeneralSample]) -> None:
        check_owner(self, state)
        state.work.record(times, out)

    def observe(self, samples: Sequence[GeneralSample]) -> ObservedArrays:
        """The observations of ``samples``, each run of samples taken under one model (one set
        of charts and laws) evaluated as one batch."""
        rows: dict[str, list[Any]] = {k: [] for k in OBSERVED}
        i = 0
        while i < len(samples):
            model = samples[i][2]
            j = i + 1
            while j < len(samples) and samples[j][2] is model:
                j += 1
            ts = [t for t, _, _ in samples[i:j]]
            Y = np.array([y for _, y, _ in samples[i:j]])
            rows["t"].extend(ts)
            rows["state"].extend(Y)
            for key, values in model.observe(ts, Y).items():
                rows[key].extend(values)
            i = j
        return finish_observations(rows, self.scene)

    def observe_now(self, state: State[Stepper[GeneralSystem]]) -> Observed:
        check_owner(self, state)
        return first_observation(self.observe([self.sample(state)]))

    def joint_sample(self, state: State[Stepper[GeneralSystem]], *, coordinates: bool = True) -> JointValues:
        check_owner(self, state)
        return joint_values(self.observe_now(state), self.interface.members)

    def singular_distance(self, state: State[Stepper[GeneralSystem]]) -> None:
        """A general structure has no singular sets of its equations of motion."""
        return None

    def stats(self, state: State[Stepper[GeneralSystem]]) -> Stats:
        st = state.work
        return Stats(method=self.method, steps=st.n_steps, nfev=st.nfev, restarts=st.n_restarts - 1,
                     events=st.n_events)
