"""Nodal dynamics of general structures: lumped masses, axial members, rigid bodies.

**Model.** Members are axial springs ``t = EA (l - l0)/l0`` (bars and actuators in tension
and compression, strings only when taut), with an optional axial damper ``c_i dl/dt`` (taut
members only: a slack string transmits nothing). Where a string goes slack or taut its force
kinks (without a damper) or jumps (by ``c dl/dt``, with one): no integration step may
straddle that, or its error estimate and dense output are wrong by far more than the
tolerance. So the strings' slack set is a discrete state of the system (:attr:`slack`, fixed
between restarts: a taut string's spring continues smoothly below its rest length inside a
step, a slack one stays at zero), and the crossings of ``l = l0`` are state events that
switch it (logged ``slack`` / ``taut`` with the member's index). Masses are lumped: a free node carries its
point mass and half of each attached member's mass; a rigid body carries its own mass,
shared equally by its nodes (so its centre of mass is the centroid, where the statics put
its weight), plus the point masses and half member masses at its nodes.

**Rigid bodies** keep rigid-body coordinates -- centre ``c`` and orientation ``R`` -- rather
than being modelled as nodes tied by very stiff members. Reasons: the form-finding already
describes bodies that way (the same :class:`~tensegrity_core.general.Configuration`, the
same exact tangent stiffness for the implicit solver's Jacobian); stiff ties would add
``3 n_b - 6`` artificial high frequencies per body that are pure cost (a stiffer system, a
denser Jacobian) and still let the body deform slightly; a body of coplanar nodes cannot
even be made rigid by ties in 3D without extra bracing nodes. A body with point masses
``m_k`` at world offsets ``r_k = R p_k`` from ``c`` has ``m = sum m_k``, first moment
``s = sum m_k r_k`` and inertia ``I_c = sum m_k (|r_k|^2 I - r_k r_k^T)``; with ``omega`` its
angular velocity (world frame), Newton-Euler about ``c`` reads::

    [[m I, -hat(s)], [hat(s), I_c]] [a_c; domega] = [F - omega x (omega x s); M_c - omega x (I_c omega)]

``F`` and ``M_c`` being the net force and moment about ``c`` of the member, load and weight
forces on the body's nodes -- exactly the generalised force ``P`` of the statics.

**State** ``y = (x, v)``: ``x`` is the statics' minimal coordinate ``U`` (free node
coordinates; per moving body its centre and a rotation vector ``theta`` with
``R = exp(hat(theta)) R_ref``), ``v`` its rate with the body's angular velocity in place of
``dtheta/dt`` (``dtheta/dt = J_l(theta)^-1 omega``, the inverse left Jacobian of SO(3)). The
chart is re-anchored (``R_ref <- R``, ``theta <- 0``, integrator restarted) once
``|theta|`` exceeds :data:`RECHART_ANGLE`, so it never nears its singularity at ``2 pi``.

**Evaluation**: the kernels of :mod:`tensegrity_core.sim.general.kernels` (compiled loops
with numba, or numpy arrays) compute the right-hand side, the Jacobian and the observations.

**Jacobian** (for Radau/BDF, sparse, pattern fixed by the topology)::

    d(dx/dt)/dv = blockdiag(I, J_l^-1(theta))
    d(dv/dt)/dx = -M^-1 K_T J_chart,   d(dv/dt)/dv = -M^-1 (A_r diag(c) A_r^T + G_gyro)

with ``K_T`` the statics' exact tangent stiffness of the same members, loads and weights,
``J_chart = blockdiag(I, J_l(theta))``, ``A_r`` the equilibrium matrix (taut members) and
``G_gyro`` the derivative of the velocity terms. It is exact at rest; elsewhere it leaves
out the derivatives of ``M``, of the damper directions and of the chart map, which only
slows the Newton iterations of the implicit method, never changes the solution.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.events import EventKind
from tensegrity_core.general.rotation import cross, exact_rotations, exp_so3
from tensegrity_core.general.statics import group_sum
from tensegrity_core.general.structure import Structure
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.event_location import Crossing
from tensegrity_core.sim.general.kernels import arrays, loops
from tensegrity_core.sim.general.kernels.array_stages import ArrayStages
from tensegrity_core.sim.general.kernels.evaluator import Evaluation, Evaluator
from tensegrity_core.sim.general.kernels.flat_layout import FlatLayout
from tensegrity_core.sim.general.kernels.flat_stages import FlatStages, flat_ready
from tensegrity_core.sim.general.kernels.plan import Plan, build_plan, frozen
from tensegrity_core.sim.general.kernels.stages import CompiledStages
from tensegrity_core.sim.inputs import Law, next_breakpoint
from tensegrity_core.sim.stepper import Transition

FloatArray = NDArray[np.float64]

#: Re-anchor a body's rotation chart when its rotation vector exceeds this angle [rad].
RECHART_ANGLE = 1.0


class NodalMasses:
    """Lumped masses of a structure and its rigid bodies' inertia in their reference frames."""

    def __init__(self, structure: Structure):
        lay = structure.layout
        m: FloatArray = structure.node_masses.copy()
        np.add.at(m, structure.members[:, 0], 0.5 * structure.member_masses)
        np.add.at(m, structure.members[:, 1], 0.5 * structure.member_masses)
        for slot, idx in enumerate(lay.body_nodes):
            m[idx] += lay.body_masses[slot] / len(idx)
        for body in structure.bodies:
            if body.fixed:
                m[list(body.nodes)] += body.mass / len(body.nodes)
        self.node = m
        free_nodes = np.flatnonzero((lay.free_index >= 0).any(axis=1))
        light = [structure.node_names[i] for i in free_nodes if m[i] <= 0.0]
        if light:
            raise SceneError(f"inertia needs a mass on every free node; {', '.join(map(repr, light[:5]))} "
                             f"{'have' if len(light) > 1 else 'has'} none (give point masses, member masses or "
                             f"body masses in the structure)", key=("effects",))
        self.free = m[np.nonzero(lay.free_index >= 0)[0]]          # per free coordinate
        on: NDArray[np.bool_] = lay.node_body >= 0
        self.on = on
        self.slot: NDArray[np.int64] = lay.node_body[on]
        self.p: FloatArray = lay.offsets[on]                         # body-frame offsets
        self.m_on = m[on]
        nb = len(lay.moving_bodies)
        self.body: FloatArray = group_sum(self.slot, self.m_on[:, None], nb)[:, 0] if nb else np.zeros(0)
        bad = [lay.body_names[b] for b in range(nb) if self.body[b] <= 0.0]
        if bad:
            raise SceneError(f"inertia needs mass on every moving rigid body; {', '.join(map(repr, bad))} "
                             f"{'has' if len(bad) == 1 else 'have'} none (give the body a 'mass' [kg] in the "
                             f"structure's rigid_bodies, or its nodes point masses)", key=("effects",))
        self.s_body: FloatArray
        self.I_body: FloatArray
        if nb:
            self.s_body = group_sum(self.slot, self.m_on[:, None] * self.p, nb)
            pp = np.einsum("ki,kj->kij", self.p, self.p)
            I = np.einsum("k,kij->kij", self.m_on, np.sum(self.p * self.p, 1)[:, None, None] * np.eye(3) - pp)
            self.I_body = group_sum(self.slot, I.reshape(-1, 9), nb).reshape(nb, 3, 3)
        else:
            self.s_body = np.zeros((0, 3))
            self.I_body = np.zeros((0, 3, 3))


class GeneralSystem:
    """Equations of motion of a general structure for one scene, with the rotation charts
    ``R_ref`` (nb, 3, 3) and the rest lengths ``rest_lengths_of`` (``t -> (m,)`` under the
    input ``laws``, or None without actuators) and the strings' slack set :attr:`slack` of one
    stretch of integration: an :class:`~tensegrity_core.sim.stepper.OdeSystem`. Immutable: a
    re-charting, a string's event or a new command gives a new instance (:meth:`with_chart`,
    :meth:`with_slack`, :meth:`with_inputs`)."""

    #: No contacts: the contact mode is always empty.
    mode: frozenset[int] = frozenset()
    #: Per string (:attr:`strings`): slack in this stretch of integration; None until a state
    #: has set it (:meth:`resume`; then ``l < l0`` decides, as in the statics).
    slack: NDArray[np.bool_] | None = None

    def __init__(self, structure: Structure, *, masses: NodalMasses, damping: FloatArray | None = None,
                 gravity: ArrayLike | None = None, loads: FloatArray | None = None,
                 rest_lengths_of: Callable[[float], FloatArray] | None = None, laws: Iterable[Law] = (),
                 actuators: ArrayLike = (), R_ref: ArrayLike, kernels: str | None = None):
        self.structure = structure
        lay = structure.layout
        self.lay = lay
        self.n = lay.n_dof
        self.masses = masses
        self.nb = len(lay.moving_bodies)
        self.n_free = lay.n_free
        self.EA = structure.EA
        self.is_string = structure.is_string
        self.actuators = np.asarray(actuators, dtype=int)
        self.rest_lengths_of = rest_lengths_of          # t -> rest lengths (m,)
        self.laws = tuple(laws)
        self.R_ref = np.array(R_ref, dtype=float)
        weights = None
        if gravity is not None:
            weights = masses.node[:, None] * np.asarray(gravity, dtype=float)[None, :]
        ext = np.zeros((structure.n_nodes, 3))
        if loads is not None:
            ext += loads
        if weights is not None:
            ext += weights
        self.external = ext if (loads is not None or weights is not None) else None
        self.state_names = tuple(f"x_{s}" for s in lay.labels()) + tuple(f"v_{s}" for s in lay.labels())
        self.plan = build_plan(structure, free_masses=masses.free, body_masses=masses.body,
                               body_first_moments=masses.s_body, body_inertia=masses.I_body, damping=damping,
                               external=self.external)
        self.evaluator = Evaluator(self.plan, kernels)
        self.geometric_plan = self.plan            # strings slack where l < l0 (no slack set)
        self.strings = np.flatnonzero(self.is_string).astype(np.int64)
        # strings whose rest length an input law moves: their gap's rate is not known here
        self._moving = np.flatnonzero(np.isin(self.strings, self.actuators))
        self._rest_lengths = np.array(structure.rest_lengths, dtype=float)   # writable: the kernels' kind of array

    def with_chart(self, R_ref: ArrayLike) -> GeneralSystem:
        """The same equations with other rotation charts."""
        new = copy.copy(self)
        new.R_ref = np.array(R_ref, dtype=float)
        return new

    def with_inputs(self, rest_lengths_of: Callable[[float], FloatArray] | None, laws: Iterable[Law]) -> GeneralSystem:
        """The same equations under other input laws (a new command)."""
        new = copy.copy(self)
        new.rest_lengths_of, new.laws = rest_lengths_of, tuple(laws)
        return new

    def next_breakpoint(self, t: float) -> float:
        return next_breakpoint(self.laws, t, math.inf)

    def rest_lengths(self, t: float) -> FloatArray:
        """The members' rest lengths [m] at ``t`` (do not modify the array)."""
        if self.rest_lengths_of is None:
            return self._rest_lengths
        return self.rest_lengths_of(t)

    # -- right-hand side ------------------------------------------------------------------------
    def fun(self, t: float, y: FloatArray) -> FloatArray:
        """``dy/dt`` at ``(t, y)`` (the kernels of :attr:`evaluator`)."""
        return self.evaluator.derivative(np.asarray(y, dtype=float), self.R_ref, self.rest_lengths(t))

    def evaluate(self, t: ArrayLike, y: ArrayLike) -> Evaluation:
        """The states ``y`` (B, 2 n_dof) at times ``t`` (B,) [s] evaluated at once (in this
        model's charts and input laws): rates, node positions, member lengths and forces."""
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        Y = np.atleast_2d(np.asarray(y, dtype=float))
        l0 = np.stack([self.rest_lengths(float(tk)) for tk in ts])
        return self.evaluator.evaluate(Y, np.broadcast_to(self.R_ref, (len(ts),) + self.R_ref.shape), l0)

    @property
    def stages(self) -> CompiledStages | ArrayStages | FlatStages:
        """Whole steps for the integrators of :mod:`tensegrity_core.sim.integrators`: compiled
        (RK4, DOP853) with numba, in numpy (RK4) with the numpy kernels (in one flat buffer
        for a model without moving bodies whose slack set is known: :mod:`.flat_stages`);
        their stretches of steps stop where a string may go slack or taut (:meth:`events`)
        or a chart is due (:meth:`after_step`)."""
        moving = np.zeros(len(self.strings), dtype=bool)
        moving[self._moving] = True
        constant = self.rest_lengths_of is None
        if self.evaluator.sums is not None and flat_ready(self.plan):
            shared = self.evaluator.shared
            if "flat" not in shared:
                shared["flat"] = FlatLayout(self.plan)
            return FlatStages(self.plan, self.rest_lengths, constant, strings=self.strings, moving=moving,
                              layout=shared["flat"])
        if self.evaluator.sums is not None:
            return ArrayStages(self.plan, self.evaluator.sums, self.R_ref, self.rest_lengths, constant,
                               strings=self.strings, moving=moving, rechart_angle=RECHART_ANGLE)
        return CompiledStages(self.plan, self.R_ref, self.rest_lengths, constant, strings=self.strings,
                              moving=moving, rechart_angle=RECHART_ANGLE)

    # -- Jacobian --------------------------------------------------------------------------------
    def jac(self, t: float, y: FloatArray) -> Any:
        """The Jacobian ``d(dy/dt)/dy`` as a scipy.sparse CSC matrix (untyped: Any; see the module docstring)."""
        return self.evaluator.jacobian(np.asarray(y, dtype=float), self.R_ref, self.rest_lengths(t))

    # -- stepper hooks ------------------------------------------------------------------------------
    def events(self) -> list[StringEvent]:
        """The strings going slack (``l`` falls through ``l0``) or taut (rises through it): one
        vectorised event with a component per string (none without strings)."""
        return [StringEvent(self)] if self.strings.size else []

    def handle_event(self, crossing: Crossing, y: FloatArray) -> Transition[GeneralSystem]:
        """String ``crossing.index`` went slack (falling) or taut (rising): the system with it
        so, logged as ``slack`` / ``taut`` with the member's index; the state as it is."""
        slack = self._geometric_slack(crossing.t, y) if self.slack is None else self.slack.copy()
        slack[crossing.component] = crossing.falling
        return Transition(np.asarray(y, dtype=float), self.with_slack(slack),
                          (("slack" if crossing.falling else "taut", crossing.index),))

    def after_step(self, t: float, y: FloatArray) -> Transition[GeneralSystem] | None:
        """Re-anchor rotation charts whose angle exceeds :data:`RECHART_ANGLE`: the state and the
        system of the new charts, or None."""
        if not self.nb:
            return None
        rot = self.lay.body_dof[:, None] + 3 + np.arange(3)[None, :]
        theta = y[rot]
        big = np.linalg.norm(theta, axis=1) > RECHART_ANGLE
        if not big.any():
            return None
        y = y.copy()
        R_ref = self.R_ref.copy()
        R_ref[big] = exp_so3(theta[big]) @ R_ref[big]
        y[rot[big]] = 0.0
        return Transition(y, self.with_chart(R_ref))

    def resume(self, t: float, y: FloatArray) -> Transition[GeneralSystem]:
        """The strings' slack set at ``(t, y)`` under this system's input laws (``l < l0``; at
        ``l = l0`` exactly, slack if shortening), and the state as it is."""
        y = np.asarray(y, dtype=float)
        if not self.strings.size:
            return Transition(y, self)
        return Transition(y, self.with_slack(self._geometric_slack(t, y)))

    def with_slack(self, slack: ArrayLike) -> GeneralSystem:
        """The same equations with the strings' slack set ``slack`` (per :attr:`strings`): in
        the kernels' plan a taut string is a member that also carries compression, a slack one
        a member of zero stiffness and damping."""
        new = copy.copy(self)
        new.slack = np.array(slack, dtype=bool)
        new.plan = _with_slack(self.geometric_plan, self.strings, new.slack)
        new.evaluator = self.evaluator.with_plan(new.plan)
        return new

    def string_gaps(self, t: float, y: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Per string (:attr:`strings`): ``l - l0`` [m] at ``(t, y)`` and its rate [m/s] (nan for
        strings whose rest length an input moves)."""
        plan = self.plan
        n, nb = plan.n_nodes, len(plan.body_dof)
        l0 = self.rest_lengths(t)
        sums = self.evaluator.sums
        if sums is None:
            gap, rate = np.empty(len(self.strings)), np.empty(len(self.strings))
            loops.string_gaps(plan.base, plan.free_node, plan.free_axis, plan.on_node, plan.on_body, plan.on_offset,
                              plan.body_dof, plan.member_a, plan.member_b, self.strings, np.array(y, dtype=float),
                              self.R_ref, np.array(l0, dtype=float), np.empty((n, 3)), np.empty((n, 3)),
                              np.empty((nb, 3, 3)), np.empty((len(plan.on_node), 3)), gap, rate)
        else:
            X, V = np.empty((1, n, 3)), np.empty((1, n, 3))
            arrays.place(plan.base, plan.free_node, plan.free_axis, plan.on_node, sums.bodies,
                         np.asarray(y, dtype=float)[None, :], self.R_ref[None], X, V, np.empty((1, nb, 3, 3)))
            a, b = plan.member_a[self.strings], plan.member_b[self.strings]
            h = X[0, b] - X[0, a]
            lengths = np.sqrt(np.einsum("ij,ij->i", h, h))
            gap = lengths - l0[self.strings]
            rate = np.einsum("ij,ij->i", h, V[0, b] - V[0, a]) / lengths
        if self._moving.size:
            rate[self._moving] = np.nan
        return gap, rate

    def _geometric_slack(self, t: float, y: FloatArray) -> NDArray[np.bool_]:
        gap, rate = self.string_gaps(t, y)
        slack: NDArray[np.bool_] = (gap < 0.0) | ((gap == 0.0) & (rate < 0.0))
        return slack

    def observe(self, t: ArrayLike, y: ArrayLike) -> dict[str, FloatArray]:
        """What the back end reports of states ``y`` (B, 2 n_dof) at times ``t`` (B,) [s] in
        this model's charts and laws, each (B, ...): ``q`` (rotation vectors from the drawing),
        ``qdot``, ``applied_forces`` (actuators' rest lengths [m]), ``nodes`` [m],
        ``member_lengths`` [m], ``member_forces`` [N], ``potential_energy`` and
        ``kinetic_energy`` [J]; per member ``member_rest_lengths`` [m], ``member_rates``
        (dl/dt [m/s]) and ``member_slack`` (a string shorter than its rest length); per moving
        body ``body_positions`` (its centre [m]), ``body_orientations`` (unit quaternions
        ``(x, y, z, w)``, ``w >= 0``, of its rotation from the drawing), ``body_velocities``
        [m/s] and ``body_angular_velocities`` [rad/s] (world frame)."""
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        Y = np.atleast_2d(np.asarray(y, dtype=float))
        n, B = self.n, len(ts)
        ev = self.evaluate(ts, Y)
        l0 = np.stack([self.rest_lengths(float(tk)) for tk in ts])
        stretch = ev.lengths - l0
        taut = ~(self.is_string & (stretch < 0.0))
        strain = 0.5 * np.sum(np.where(taut, self.EA * stretch**2 / l0, 0.0), axis=1)
        work = np.zeros(B) if self.external is None else np.einsum("bki,ki->b", ev.positions, self.external)
        q = Y[:, :n].copy()
        quat = np.zeros((B, 0, 4))
        if self.nb:
            rotations = exact_rotations(ev.rotations.reshape(-1, 3, 3))     # one conversion for both
            rot = self.lay.body_dof[:, None] + 3 + np.arange(3)[None, :]
            q[:, rot] = rotations.as_rotvec().reshape(B, self.nb, 3)
            quat = rotations.as_quat().reshape(B, self.nb, 4)
        a, b = self.structure.members[:, 0], self.structure.members[:, 1]
        h = ev.positions[:, b] - ev.positions[:, a]
        rates = np.einsum("bmi,bmi->bm", h, ev.velocities[:, b] - ev.velocities[:, a]) / ev.lengths
        body = self.lay.body_dof[:, None] + np.arange(3)[None, :]
        return {"q": q, "qdot": Y[:, n:].copy(), "applied_forces": l0[:, self.actuators],
                "nodes": ev.positions, "member_lengths": ev.lengths, "member_forces": ev.forces,
                "potential_energy": strain - work, "kinetic_energy": self.kinetic_energy(Y, ev.rotations),
                "member_rest_lengths": l0, "member_rates": rates, "member_slack": ~taut,
                "body_positions": Y[:, body], "body_orientations": np.where(quat[..., 3:] < 0.0, -quat, quat),
                "body_velocities": Y[:, n + body], "body_angular_velocities": Y[:, n + body + 3]}

    def kinetic_energy(self, y: FloatArray, R: FloatArray) -> FloatArray:
        """Kinetic energy [J] (B,) of states ``y`` (B, 2 n_dof) whose bodies have rotations
        ``R`` (B, nb, 3, 3) (:func:`kinetic_energy`)."""
        m = self.masses
        return kinetic_energy(y[:, self.n:], R, m.free, self.lay.body_dof, m.body, m.s_body, m.I_body)


def kinetic_energy(v: FloatArray, R: FloatArray, free_mass: FloatArray, body_dof: ArrayLike, body_mass: FloatArray,
                   first_moment: FloatArray, inertia: FloatArray) -> FloatArray:
    """Kinetic energy [J] (B,) of rates ``v`` (B, n_dof) (free coordinates first, then per
    body ``v_c`` and ``w`` at ``body_dof``) with the bodies' rotations ``R`` (B, nb, 3, 3):
    ``1/2 sum m v^2`` of the free coordinates (lumped masses ``free_mass`` [kg]) plus, per
    body of mass ``m``, first moment ``s`` and inertia ``I_c`` about ``c`` (body frame),
    ``1/2 (m |v_c|^2 + 2 v_c . (w x s) + w . I_c w)``."""
    T: FloatArray = 0.5 * np.sum(free_mass * v[:, :len(free_mass)] ** 2, axis=1)
    dof = np.asarray(body_dof, dtype=int)
    if len(dof):
        cols = dof[:, None] + np.arange(3)[None, :]
        vc, w = v[:, cols], v[:, cols + 3]
        s = np.einsum("bkij,kj->bki", R, first_moment)
        Iw = np.einsum("bkij,bkj->bki", R, np.einsum("kij,bkj->bki", inertia, np.einsum("bkji,bkj->bki", R, w)))
        T = T + 0.5 * np.sum(body_mass * np.sum(vc * vc, axis=2)
                             + 2.0 * np.sum(vc * cross(w, s), axis=2) + np.sum(w * Iw, axis=2), axis=1)
    return T


def _with_slack(plan: Plan, strings: NDArray[np.int64], slack: NDArray[np.bool_]) -> Plan:
    """``plan`` with the strings ``strings`` in the slack set ``slack``: no string decides by
    its length any more; the slack ones have no stiffness or damping."""
    EA, damping, is_string = plan.EA.copy(), plan.damping.copy(), plan.is_string.copy()
    gone = strings[slack]
    EA[gone] = 0.0
    damping[gone] = 0.0
    is_string[strings] = False
    return frozen(plan._replace(EA=EA, damping=damping, is_string=is_string))


@dataclass(frozen=True)
class StringEvent:
    """The strings of ``system`` going slack (a component falls through zero) or taut (rises):
    components ``l - l0(t)`` [m] per string, with rates ``dl/dt - dl0/dt`` [m/s] (nan where
    unknown). A :class:`~tensegrity_core.sim.event_location.StateEvent` of both directions, named
    by the member's index."""

    system: GeneralSystem
    kind: EventKind = "slack"
    direction: float = 0.0
    hard_stop: bool = False

    @property
    def indices(self) -> tuple[int, ...]:
        return tuple(int(i) for i in self.system.strings)

    def g(self, t: float, y: FloatArray) -> FloatArray:
        return self.system.string_gaps(t, y)[0]

    def values(self, t: float, y: FloatArray) -> tuple[FloatArray, FloatArray]:
        return self.system.string_gaps(t, y)
