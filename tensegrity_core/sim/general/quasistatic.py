"""General structures without inertia: incremental form-finding along the scene's inputs.

At each time the configuration is the stable equilibrium of the members (with the
actuators' current rest lengths), the dead loads and the weights, found by the statics'
Newton form-finding restarted from the previous configuration (an increment, usually a
few iterations, or none when nothing changed). When no stable equilibrium continues the
path (a limit point: the structure would snap or collapse), the run stops with a
:class:`SimulationError`. The rate ``dU/dt`` of the path follows from differentiating the
balance ``P = G^T f + w - A_r t = 0`` (the statics' Eq. 64) in time:
``K_T dU/dt = -A_r diag(dt/dl0) dl0/dt`` with ``dt/dl0 = -EA l / l0^2`` for taut members.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse.linalg import spsolve

from tensegrity_core.events import LoggedEvent
from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.statics import equilibrium_matrix, member_forces, member_lengths, potential_energy
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure
from tensegrity_core.sim.commands import changed, check_command
from tensegrity_core.sim.errors import check_advance_target
from tensegrity_core.sim.general.setup import (
    OBSERVED,
    GeneralBackEnd,
    RestLengths,
    coordinates,
    equilibrium,
    finish_observations,
    first_observation,
    general_model,
    initial_configuration,
    minimal_coordinates,
    quaternions,
    rest_lengths_function,
    scene_loads,
    static_structure,
)
from tensegrity_core.sim.inputs import held
from tensegrity_core.sim.model import (
    JointValues,
    Model,
    Observed,
    ObservedArrays,
    State,
    Stats,
    check_owner,
    joint_values,
)
from tensegrity_core.sim.scene import Scene

FloatArray = NDArray[np.float64]
#: What an observation needs at one time: ``(t [s], equilibrium, static structure, rest-lengths law)``.
GeneralQuasiStaticSample = tuple[float, Configuration, Structure, RestLengths | None]


class FormFindingPath:
    """The integrator of a quasi-static general state: the equilibrium ``config`` at ``t`` of
    the ``static`` structure (rest lengths ``l0`` from ``rest_of``, or the drawn ones). A
    general structure has no contacts: its mode is always empty."""

    mode: frozenset[int] = frozenset()

    def __init__(self, t: float, config: Configuration, static: Structure, rest_of: RestLengths | None,
                 n_solves: int = 0):
        self.t = t
        self.config = config
        self.static = static
        self.rest_of = rest_of
        self.n_solves = n_solves

    @property
    def l0(self) -> FloatArray:
        l0: FloatArray = self.static.rest_lengths
        return l0

    @property
    def y(self) -> FloatArray:
        lay = self.static.layout
        return minimal_coordinates(lay, coordinates(self.config), self.config.rotations)

    def copy(self, events: list[LoggedEvent]) -> FormFindingPath:
        """An exact copy (configurations and structures are immutable)."""
        return FormFindingPath(self.t, self.config, self.static, self.rest_of, self.n_solves)

    def rest(self, t: float) -> FloatArray:
        return self.l0 if self.rest_of is None else self.rest_of(t)

    def solve(self, x0: Configuration, t: float, what: str) -> Configuration:
        self.n_solves += 1
        return equilibrium(self.static, x0, what=what, t=t)

    def update(self, t: float) -> None:
        """The equilibrium at ``t`` (a new form-finding only when the rest lengths changed)."""
        l0 = self.rest(t)
        if np.array_equal(l0, self.l0):
            return
        self.static = self.static.with_rest_lengths(l0)
        self.config = self.solve(self.config, t, f"at t = {t:.9g} s for the actuators' rest lengths (a limit "
                                 f"point: the structure would snap, which needs inertia)")


class GeneralQuasiStatic(GeneralBackEnd, Model[FormFindingPath, GeneralQuasiStaticSample]):
    """Back end ``general/quasi-static``: the equilibrium path of a general structure
    (implements :class:`~tensegrity_core.sim.model.Model`); the equilibrium at ``t = 0`` is
    found once, at compile time."""

    quasi_static = True
    method = "quasi-static (incremental form-finding)"

    def __init__(self, scene: Scene):
        super().__init__(scene)
        s = self.structure
        self.state_names = tuple(f"x_{v}" for v in s.layout.labels())
        self.actuators = list(general_model(scene).actuators)
        rest_of = rest_lengths_function(scene, held(self.laws, self.initial_commands))
        l0 = s.rest_lengths if rest_of is None else rest_of(0.0)
        start = initial_configuration(scene)
        path = FormFindingPath(0.0, start, static_structure(scene, loads=scene_loads(scene), rest_lengths=l0),
                               rest_of)
        path.config = path.solve(start, 0.0, "at t = 0 under the scene's loads")
        self._jumped = bool(np.max(np.abs(path.config.coords - start.coords)) > 1e-9 * _size(s))
        self._start = path

    # -- states ---------------------------------------------------------------------------------
    def initial_state(self, *, t_end: float = math.inf) -> State[FormFindingPath]:
        """The equilibrium at ``t = 0`` under the scene's loads (event ``jump`` when it is not
        the initial configuration)."""
        return State(self.initial_commands, [(0.0, "jump", 0)] if self._jumped else [], self._start.copy([]), owner=self)

    # -- running ------------------------------------------------------------------------------
    def set_command(self, state: State[FormFindingPath], values: Iterable[float]) -> None:
        check_owner(self, state)
        commands = check_command(values, self.laws, self.actuator_names, positive=True)
        if not changed(state.commands, commands):
            return
        state.commands = commands
        state.work.rest_of = rest_lengths_function(self.scene, held(self.laws, commands))
        state.work.update(state.t)

    def advance(self, state: State[FormFindingPath], t: float) -> None:
        check_owner(self, state)
        path = state.work
        check_advance_target(path.t, t)
        path.update(t)
        path.t = t

    def sample(self, state: State[FormFindingPath]) -> GeneralQuasiStaticSample:
        """``(t, configuration, static structure, rest-lengths law)`` at ``state.t``."""
        path = state.work
        return path.t, path.config, path.static, path.rest_of

    def record(self, state: State[FormFindingPath], times: Sequence[float] | FloatArray,
               out: list[GeneralQuasiStaticSample]) -> None:
        check_owner(self, state)
        for t in times:
            self.advance(state, float(t))
            out.append(self.sample(state))

    def _rates(self, t: float, config: Configuration, static: Structure,
               rest_of: RestLengths | None) -> tuple[FloatArray, FloatArray]:
        """``(dU/dt, dl/dt)`` of the equilibrium path (zero when the rest lengths do not change):
        the members' length rates by compatibility, ``dl/dt = A^T dU/dt`` (``A`` the equilibrium
        matrix, whose column ``j`` is ``dl_j/dU``)."""
        n, m = self.structure.layout.n_dof, self.structure.n_members
        if rest_of is None:
            return np.zeros(n), np.zeros(m)
        dl0 = np.zeros(m)
        dl0[self.actuators] = [law.d_time(t, 0.0) for law in rest_of.laws]
        if not np.any(dl0):
            return np.zeros(n), np.zeros(m)
        lengths = member_lengths(static, config.coords)
        taut = ~(static.is_string & (lengths < static.rest_lengths))
        dt_dl0 = np.where(taut, -static.EA * lengths / static.rest_lengths**2, 0.0)
        A = equilibrium_matrix(static, config, sparse=True)
        K = tangent_stiffness(static, config, sparse=True)
        rate: FloatArray = np.atleast_1d(spsolve(K.tocsc(), -(A @ (dt_dl0 * dl0))))
        return rate, np.asarray(A.T @ rate, dtype=float)

    def observe(self, samples: Sequence[GeneralQuasiStaticSample]) -> ObservedArrays:
        rows: dict[str, list[Any]] = {k: [] for k in OBSERVED}
        lay = self.structure.layout
        body = lay.body_dof[:, None] + np.arange(3)[None, :]
        for t, config, static, rest_of in samples:
            q = minimal_coordinates(lay, coordinates(config), config.rotations)
            rate, length_rate = self._rates(t, config, static, rest_of)
            lengths = member_lengths(static, config.coords)
            rows["t"].append(t)
            rows["state"].append(q)
            rows["q"].append(q)
            rows["qdot"].append(rate)
            rows["applied_forces"].append(static.rest_lengths[self.actuators])
            rows["nodes"].append(config.coords)
            rows["member_lengths"].append(lengths)
            rows["member_forces"].append(member_forces(static, config.coords))
            rows["member_rest_lengths"].append(static.rest_lengths)
            rows["member_rates"].append(length_rate)
            rows["member_slack"].append(static.is_string & (lengths < static.rest_lengths))
            rows["body_positions"].append(config.centres)
            rows["body_orientations"].append(quaternions(config.rotations))
            rows["body_velocities"].append(rate[body])
            rows["body_angular_velocities"].append(rate[body + 3])
            rows["potential_energy"].append(potential_energy(static, config.coords))
            rows["kinetic_energy"].append(0.0)
        return finish_observations(rows, self.scene)

    def observe_now(self, state: State[FormFindingPath]) -> Observed:
        check_owner(self, state)
        return first_observation(self.observe([self.sample(state)]))

    def joint_sample(self, state: State[FormFindingPath], *, coordinates: bool = True) -> JointValues:
        check_owner(self, state)
        return joint_values(self.observe_now(state), self.interface.members)

    def singular_distance(self, state: State[FormFindingPath]) -> None:
        """A general structure has no singular sets of the class-2 kind."""
        return None

    def stats(self, state: State[FormFindingPath]) -> Stats:
        return Stats(method=self.method, form_finds=state.work.n_solves, events=len(state.events))


def _size(structure: Structure) -> float:
    return max(float(np.ptp(structure.nodes, axis=0).max()), 1e-300)
