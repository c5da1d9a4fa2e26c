"""The class-2 mechanism without inertia: the configuration tracks a stable equilibrium.

With massless struts the equations of motion ``M qddot + C = Q - (T, 0)`` reduce to the
force balance ``Q(q) = (f1, f2, 0)``. Every input law depends on time and on its own length
only, so at frozen ``t`` the actuator force is conservative, and the balance is the
stationarity of the total potential ``Pi(q, t)`` (:mod:`.potential`). So with forces
as inputs the actuator lengths are *unknowns*: ``dPi/drho_i = 0`` says the actuator force
balances the springs' generalised force, ``dPi/dbeta = 0`` is the paper's Eq. (10) for the
angle. The quasi-static configuration is a local minimum of ``Pi(., t)`` followed
continuously in ``t``; with the fold limit the minimum is taken over ``rho_i >= 0`` and a held
actuator carries the contact force ``lambda_i = dPi/drho_i >= 0`` (KKT).

**Path following** (:mod:`.path`, on the equilibria of :mod:`.equilibria`). ``G = dPi/dq`` restricted to the coordinates not held (``F``) defines a
curve ``G_F(q, t) = 0``. It is followed by pseudo-arclength continuation in the scaled
variables ``z = (q/L, t/T)`` (``T`` the scene's duration): the tangent ``v`` spans the null
space of ``[K_FF L, dG_F/dt T]`` (``K = d2Pi/dq2``), the predictor is ``z + ds v`` plus the
curvature term from the tangents' change over the last step, and Newton corrects on
``G_F = 0`` plus ``v . (z - z_pred) = 0``. Unlike stepping in ``t``, this stays
regular where ``dq/dt`` is infinite -- which happens in the paper's scenario, where the
stable branch meets the fold with a vertical tangent. The step ``ds`` is controlled by the
predictor's error (:data:`PATH_TOL`). An accepted point must be a stable equilibrium
(``K_FF`` positive definite) reached forward in time.

**Events** along the path (:mod:`.path_events`): an actuator reaching zero length
(``fold``: held from then on), a held actuator whose contact force falls to zero
(``release``), an input law's breakpoint, and a **limit point**: time would have to run
backwards to stay on the branch, i.e. the equilibrium stops existing because the forces
exceed what the springs can resist. The quasi-static model cannot continue there (the
mechanism would snap; that needs inertia): the run stops with a :class:`SimulationError`.
Events are located by Newton on the path's equations plus the event's own (quadratically
convergent), a degenerate contact as the bifurcation of the held branch. An event at a
sample's time (to rounding) comes before the sample.

Observed samples come from :mod:`.path_samples` (the segments' interpolants polished
into exact equilibria). If the initial state is not an equilibrium under the inputs at
``t = 0`` (e.g. the paper's start: the equilibrium angle for locked actuators, but zero
actuator force), the model starts from the minimum of ``Pi(., 0)`` reached by descent from
it (event ``jump``); a changed command does the same at its time.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.names import STATE_NAMES
from tensegrity_core.sim.class2 import path_samples as samples
from tensegrity_core.sim.class2.equilibria import Equilibria, PathCounts, PathSettings, bits_of
from tensegrity_core.sim.class2.observe import Class2Observer
from tensegrity_core.sim.class2.path import PathFollower
from tensegrity_core.sim.class2.path_samples import Segment
from tensegrity_core.sim.class2.potential import TotalPotential
from tensegrity_core.sim.class2.setup import (
    NAMES,
    class2_interface,
    class2_params,
    conservative,
    force_effects,
    initial_configuration,
    singular_distance,
    static_force,
)
from tensegrity_core.sim.commands import changed, check_command, compile_inputs
from tensegrity_core.sim.inputs import held
from tensegrity_core.sim.model import (
    Frozen,
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

#: Samples of one segment under one potential: ``(times (k,) [s], segment, total potential)``.
Class2Block = tuple[NDArray[np.float64], Segment, TotalPotential]


class Class2QuasiStatic(Frozen, Model[PathFollower, Class2Block]):
    """Back end ``class2/quasi-static``: the equilibrium path of a class-2 scene without
    inertia (implements :class:`~tensegrity_core.sim.model.Model`). The path's start at
    ``t = 0`` is found once, at compile time; a state's integrator is a
    :class:`~tensegrity_core.sim.class2.path.PathFollower`."""

    kind = "class2"
    quasi_static = True
    method = "quasi-static (pseudo-arclength continuation)"
    names = NAMES
    state_names = STATE_NAMES

    def __init__(self, scene: Scene):
        params = class2_params(scene)
        self.scene = scene
        self.params = params
        self.L = params.L
        self.T = scene.duration
        self.effects = conservative(force_effects(scene))
        q0, _ = initial_configuration(scene, self.effects)
        self.laws, self.actuator_names, self.initial_commands = compile_inputs(
            scene.inputs, static_force(self.effects, self.L, q0)[:2])
        self.interface = class2_interface(self.actuator_names, self.laws)
        self.observer = Class2Observer(scene, self.effects, inertia=False)
        fold = "fold_limit" in scene.effects
        force_scale = max(params.k1, params.k2, params.k3, params.k4) * params.L
        # A contact force must be clearly tensile to release: at a degenerate contact
        # (lambda = 0, as at the paper's full fold) rounding must not make the stop chatter.
        self.settings = PathSettings(L=self.L, T=self.T, fold=fold, tol=1e-12 * force_scale,
                                     release_tol=1e-9 * force_scale,
                                     ds_max=min(scene.integrator.max_step, scene.duration) / (4.0 * scene.duration))
        start = PathFollower(self._equilibria(self.initial_commands, PathCounts()), [])
        start.jump(0.0, q0, bits_of(i for i in (0, 1) if fold and q0[i] <= 0.0))
        self._start = start

    def _equilibria(self, commands: Sequence[float], counts: PathCounts) -> Equilibria:
        return Equilibria(TotalPotential(self.effects, held(self.laws, commands), self.L), self.settings, counts)

    # -- states ---------------------------------------------------------------------------------
    def initial_state(self, *, t_end: float = math.inf) -> State[PathFollower]:
        """The path's start at ``t = 0`` (the minimum reached from the scene's initial state,
        found once at compile time; ``t_end`` is not needed: the path never runs ahead)."""
        events = list(self._start.events)
        return State(self.initial_commands, events, self._start.copy(events), owner=self)

    def potential(self, state: State[PathFollower]) -> TotalPotential:
        """The total potential the state's path follows (its effects under its commands)."""
        return state.work.potential

    # -- running ------------------------------------------------------------------------------
    def set_command(self, state: State[PathFollower], values: Iterable[float]) -> None:
        check_owner(self, state)
        commands = check_command(values, self.laws, self.actuator_names)
        if not changed(state.commands, commands):
            return
        state.commands = commands
        state.work.with_laws(held(self.laws, commands))
        state.work.jump_here()

    def advance(self, state: State[PathFollower], t: float) -> None:
        check_owner(self, state)
        state.work.advance(t)

    def sample(self, state: State[PathFollower]) -> Class2Block:
        """The current time with its segment and potential: a block of one sample for :meth:`observe`."""
        return np.array([state.t]), state.work.seg, state.work.potential

    def record(self, state: State[PathFollower], times: Sequence[float] | NDArray[np.float64],
               out: list[Class2Block]) -> None:
        """Append blocks ``(times inside one segment, segment, potential)`` for increasing
        ``times`` to ``out``: the path is advanced segment by segment; :meth:`observe`
        evaluates them."""
        check_owner(self, state)
        blocks: list[samples.Block] = []
        try:
            state.work.record(times, blocks)
        finally:
            potential = state.work.potential
            out.extend((t, seg, potential) for t, seg in blocks)

    def observe(self, blocks: Sequence[Class2Block]) -> ObservedArrays:
        """Observed quantities of recorded blocks (arrays over their samples): the segments'
        equilibria at the blocks' times under the potential each was recorded with."""
        runs: list[tuple[TotalPotential, list[samples.Block]]] = []
        for t, seg, potential in blocks:
            if runs and runs[-1][0] is potential:
                runs[-1][1].append((t, seg))
            else:
                runs.append((potential, [(t, seg)]))
        if not runs:
            runs = [(self._start.potential, [])]
        parts = [samples.equilibria(potential, run, self.L, self.T) for potential, run in runs]
        t, q, qd, lam, u, bits = (np.concatenate(arrays) for arrays in zip(*parts))
        return self.observer.many(t, np.concatenate([q, qd], axis=1), bits, u, contact=lam)

    def observe_now(self, state: State[PathFollower]) -> Observed:
        """The observation at ``state.t`` (one sample, evaluated on floats)."""
        check_owner(self, state)
        q, qd, lam, u = state.work.equilibrium_now()
        return self.observer.one(state.t, q + qd, state.work.seg.bits, u, contact=lam)

    def joint_sample(self, state: State[PathFollower], *, coordinates: bool = True) -> JointValues:
        check_owner(self, state)
        return joint_values(self.observe_now(state))

    def singular_distance(self, state: State[PathFollower]) -> tuple[str, float]:
        return singular_distance(self.params, state.y)

    def stats(self, state: State[PathFollower]) -> Stats:
        counts = state.work.counts
        return Stats(method=self.method, steps=counts.steps, newton_iterations=counts.newton,
                     events=len(state.events))
