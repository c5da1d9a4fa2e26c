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

import numpy as np
from scipy.sparse.linalg import spsolve

from tensegrity_core.general.statics import equilibrium_matrix, member_forces, member_lengths, potential_energy
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.general_sim import (
    coordinates,
    equilibrium,
    finish_observations,
    initial_configuration,
    prepare_inputs,
    rest_lengths_function,
    scene_loads,
    static_structure,
)
from tensegrity_core.sim.backend import Commands


class GeneralQuasiStatic(Commands):
    """Back end: the equilibrium path of a general structure."""

    kind = "general"
    quasi_static = True
    positive = True

    def __init__(self, scene):
        prepare_inputs(self, scene)
        s = self.structure
        self.rest_of = rest_lengths_function(scene, self.laws)
        self.loads = scene_loads(scene)
        self.events: list = []
        self.n_solves = 0
        start = initial_configuration(scene)
        self.t = 0.0
        self._l0 = self._rest(0.0)
        self._static = static_structure(scene, loads=self.loads, rest_lengths=self._l0)
        self.config = self._solve(start, 0.0, "at t = 0 under the scene's loads")
        if np.max(np.abs(self.config.coords - start.coords)) > 1e-9 * _size(s):
            self.events.append((0.0, "jump", 0))
        self.state_names = tuple(f"x_{v}" for v in s.layout.labels())

    def _rest(self, t: float) -> np.ndarray:
        return self.structure.rest_lengths if self.rest_of is None else self.rest_of(t)

    def _solve(self, x0, t: float, what: str):
        self.n_solves += 1
        return equilibrium(self._static, x0, what=what, t=t)

    def set_command(self, values) -> None:
        if self.take_command(values):
            self._update(self.t)

    def _update(self, t: float) -> None:
        l0 = self._rest(t)
        if np.array_equal(l0, self._l0):
            return
        self._l0 = l0
        self._static = self._static.with_rest_lengths(l0)
        self.config = self._solve(self.config, t, f"at t = {t:.9g} s for the actuators' rest lengths (a limit "
                                  f"point: the structure would snap, which needs inertia)")

    def advance(self, t: float) -> None:
        if t < self.t:
            raise SimulationError(f"cannot advance backwards: t = {self.t!r} s, target {t!r} s", t=self.t)
        self._update(t)
        self.t = t

    def sample(self) -> tuple:
        return self.t, self.config, self._static

    def record(self, times, out: list) -> None:
        for t in times:
            self.advance(float(t))
            out.append(self.sample())

    def names(self) -> dict:
        s = self.structure
        return {"node_names": s.node_names, "member_names": s.member_names, "member_nodes": s.members}

    def _rate(self, t: float, config, static) -> np.ndarray:
        """``dU/dt`` of the equilibrium path (zero when the rest lengths do not change)."""
        n = self.structure.layout.n_dof
        if self.rest_of is None:
            return np.zeros(n)
        dl0 = np.zeros(self.structure.n_members)
        dl0[list(self.scene.model.actuators)] = [law.d_time(t, 0.0) for law in self.laws]
        if not np.any(dl0):
            return np.zeros(n)
        lengths = member_lengths(static, config.coords)
        taut = ~(static.is_string & (lengths < static.rest_lengths))
        dt_dl0 = np.where(taut, -static.EA * lengths / static.rest_lengths**2, 0.0)
        A = equilibrium_matrix(static, config, sparse=True)
        K = tangent_stiffness(static, config, sparse=True)
        return np.atleast_1d(spsolve(K.tocsc(), -(A @ (dt_dl0 * dl0))))

    def observe(self, samples) -> dict:
        from tensegrity_core.sim.general_sim import minimal_coordinates

        rows = {k: [] for k in ("t", "state", "q", "qdot", "applied_forces", "nodes", "member_lengths",
                                "member_forces", "potential_energy", "kinetic_energy")}
        lay = self.structure.layout
        for t, config, static in samples:
            q = minimal_coordinates(lay, coordinates(config), config.rotations)
            rows["t"].append(t)
            rows["state"].append(q)
            rows["q"].append(q)
            rows["qdot"].append(self._rate(t, config, static))
            rows["applied_forces"].append(static.rest_lengths[list(self.scene.model.actuators)])
            rows["nodes"].append(config.coords)
            rows["member_lengths"].append(member_lengths(static, config.coords))
            rows["member_forces"].append(member_forces(static, config.coords))
            rows["potential_energy"].append(potential_energy(static, config.coords))
            rows["kinetic_energy"].append(0.0)
        return finish_observations(rows, self.scene)

    def stats(self) -> dict:
        return {"method": "quasi-static (incremental form-finding)", "form_finds": self.n_solves,
                "events": len(self.events)}


def _size(structure) -> float:
    return max(float(np.ptp(structure.nodes, axis=0).max()), 1e-300)
