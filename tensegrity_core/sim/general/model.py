"""Nodal dynamics of general structures: lumped masses, axial members, rigid bodies.

**Model.** Members are axial springs ``t = EA (l - l0)/l0`` (bars and actuators in tension
and compression, strings only when taut), with an optional axial damper ``c_i dl/dt`` (taut
members only: a slack string transmits nothing). Masses are lumped: a free node carries its
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

**Jacobian** (for Radau/BDF, sparse)::

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
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.rotation import cross, exp_so3, hat, left_jacobian, left_jacobian_inverse
from tensegrity_core.general.statics import equilibrium_matrix, group_sum
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.inputs import Law, next_breakpoint
from tensegrity_core.sim.stepper import StateEvent

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
                             f"has none", key=("effects",))
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
    input ``laws``, or None without actuators) of one stretch of integration: an
    :class:`~tensegrity_core.sim.stepper.OdeSystem`. Immutable: a re-charting or a new command
    gives a new instance (:meth:`with_chart`, :meth:`with_inputs`)."""

    #: No contacts: the contact mode is always empty.
    mode: frozenset[int] = frozenset()

    def __init__(self, structure: Structure, *, masses: NodalMasses, damping: FloatArray | None = None,
                 gravity: ArrayLike | None = None, loads: FloatArray | None = None,
                 rest_lengths_of: Callable[[float], FloatArray] | None = None, laws: Iterable[Law] = (),
                 actuators: ArrayLike = (), R_ref: ArrayLike):
        self.structure = structure
        lay = structure.layout
        self.lay = lay
        self.n = lay.n_dof
        self.masses = masses
        self.nb = len(lay.moving_bodies)
        self.free_nodes, self.free_axes = np.nonzero(lay.free_index >= 0)
        self.free_cols = lay.free_index[self.free_nodes, self.free_axes]
        order = np.argsort(self.free_cols)
        self.free_nodes, self.free_axes = self.free_nodes[order], self.free_axes[order]
        self.n_free = lay.n_free
        self.a = structure.members[:, 0]
        self.b = structure.members[:, 1]
        self.EA = structure.EA
        self.is_string = structure.is_string
        self.actuators = np.asarray(actuators, dtype=int)
        self.rest_lengths_of = rest_lengths_of          # t -> rest lengths (m,)
        self.laws = tuple(laws)
        self.base = structure.nodes.copy()
        self.R_ref = np.array(R_ref, dtype=float)
        self.c_damp = damping                            # (m,) axial damping [N s/m] or None
        weights = None
        if gravity is not None:
            weights = masses.node[:, None] * np.asarray(gravity, dtype=float)[None, :]
        self.gravity = None if gravity is None else np.asarray(gravity, dtype=float)
        ext = np.zeros((structure.n_nodes, 3))
        if loads is not None:
            ext += loads
        if weights is not None:
            ext += weights
        self.external = ext if (loads is not None or weights is not None) else None
        self.state_names = tuple(f"x_{s}" for s in lay.labels()) + tuple(f"v_{s}" for s in lay.labels())
        self._twin = self._statics_twin(0.0) if rest_lengths_of is None else None

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

    # -- kinematics -----------------------------------------------------------------------
    def placement(self, x: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(coords (n, 3), arms r (n_on, 3), R (nb, 3, 3))`` for coordinates ``x``."""
        coords = self.base.copy()
        coords[self.free_nodes, self.free_axes] = x[:self.n_free]
        if not self.nb:
            return coords, np.zeros((0, 3)), np.zeros((0, 3, 3))
        d = x[self.lay.body_dof[:, None] + np.arange(6)[None, :]]
        R = exp_so3(d[:, 3:]) @ self.R_ref
        r = np.einsum("kij,kj->ki", R[self.masses.slot], self.masses.p)
        coords[self.masses.on] = d[self.masses.slot, :3] + r
        return coords, r, R

    def velocities(self, v: FloatArray, r: FloatArray) -> FloatArray:
        vel = np.zeros_like(self.base)
        vel[self.free_nodes, self.free_axes] = v[:self.n_free]
        if self.nb:
            d = v[self.lay.body_dof[:, None] + np.arange(6)[None, :]]
            slot = self.masses.slot
            vel[self.masses.on] = d[slot, :3] + cross(d[slot, 3:], r)
        return vel

    def rest_lengths(self, t: float) -> FloatArray:
        if self.rest_lengths_of is None:
            l0: FloatArray = self.structure.rest_lengths
            return l0
        return self.rest_lengths_of(t)

    def member_state(self, t: float, coords: FloatArray,
                     vel: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
        """``(forces (m,), unit vectors (m, 3), lengths (m,), taut (m,))``; forces include dampers."""
        h = coords[self.b] - coords[self.a]
        lengths = np.sqrt(np.einsum("ij,ij->i", h, h))
        u = h / lengths[:, None]
        l0 = self.rest_lengths(t)
        force = self.EA * (lengths - l0) / l0
        taut = ~(self.is_string & (lengths < l0))
        if self.c_damp is not None:
            rate = np.einsum("ij,ij->i", u, vel[self.b] - vel[self.a])
            force = force + self.c_damp * rate
        return np.where(taut, force, 0.0), u, lengths, taut

    # -- right-hand side ------------------------------------------------------------------------
    def generalized_force(self, t: float, x: FloatArray,
                          v: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(P (n_dof,), coords, arms, R, member forces)``: the generalised force of members,
        dampers, loads and weights."""
        coords, r, R = self.placement(x)
        vel = self.velocities(v, r)
        force, u, _, _ = self.member_state(t, coords, vel)
        ft = force[:, None] * u
        f = group_sum(np.concatenate([self.a, self.b]), np.concatenate([ft, -ft]), len(coords))
        if self.external is not None:
            f = f + self.external
        P = np.empty(self.n)
        P[:self.n_free] = f[self.free_nodes, self.free_axes]
        if self.nb:
            fo = f[self.masses.on]
            FM = group_sum(self.masses.slot, np.concatenate([fo, cross(r, fo)], axis=1), self.nb)
            P[self.lay.body_dof[:, None] + np.arange(6)[None, :]] = FM
        return P, coords, r, R, force

    def body_matrices(self, R: FloatArray,
                      v: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """Per moving body: the 6 x 6 mass matrices and the velocity terms (nb, 6)."""
        ms = self.masses
        s = np.einsum("kij,kj->ki", R, ms.s_body)
        Ic = R @ ms.I_body @ np.swapaxes(R, 1, 2)
        Mb = np.zeros((self.nb, 6, 6))
        Mb[:, :3, :3] = ms.body[:, None, None] * np.eye(3)
        Mb[:, :3, 3:] = -hat(s)
        Mb[:, 3:, :3] = hat(s)
        Mb[:, 3:, 3:] = Ic
        w = v[self.lay.body_dof[:, None] + 3 + np.arange(3)[None, :]]
        gyro = np.concatenate([cross(w, cross(w, s)), cross(w, np.einsum("kij,kj->ki", Ic, w))], axis=1)
        return Mb, gyro, s, Ic, w

    def accelerations(self, t: float, x: FloatArray, v: FloatArray) -> FloatArray:
        P, _, _, R, _ = self.generalized_force(t, x, v)
        a = np.empty(self.n)
        a[:self.n_free] = P[:self.n_free] / self.masses.free
        if self.nb:
            Mb, gyro, _, _, _ = self.body_matrices(R, v)
            cols = self.lay.body_dof[:, None] + np.arange(6)[None, :]
            a[cols] = np.linalg.solve(Mb, (P[cols] - gyro)[..., None])[..., 0]
        return a

    def fun(self, t: float, y: FloatArray) -> FloatArray:
        n = self.n
        x, v = y[:n], y[n:]
        a = self.accelerations(t, x, v)
        xdot = v.copy()
        if self.nb:
            rot = self.lay.body_dof[:, None] + 3 + np.arange(3)[None, :]
            xdot[rot] = np.einsum("kij,kj->ki", left_jacobian_inverse(x[rot]), v[rot])
        return np.concatenate([xdot, a])

    # -- Jacobian --------------------------------------------------------------------------------
    def statics_twin(self, t: float) -> Structure:
        """The same members (current rest lengths), loads and weights as a static structure."""
        return self._twin if self._twin is not None else self._statics_twin(t)

    def _statics_twin(self, t: float) -> Structure:
        s = self.structure
        loads = np.zeros((s.n_nodes, 3)) if self.external is None else self.external
        twin = s.replace(rest_lengths=np.asarray(self.rest_lengths(t), dtype=float), loads=loads,
                         node_masses=np.zeros(s.n_nodes), member_masses=np.zeros(s.n_members),
                         gravity=np.zeros(3),
                         bodies=tuple(b.__class__(b.name, b.nodes, 0.0, b.fixed) for b in s.bodies))
        return twin

    def configuration(self, x: FloatArray, twin: Structure) -> Configuration:
        coords, _, R = self.placement(x)
        centres = x[self.lay.body_dof[:, None] + np.arange(3)[None, :]] if self.nb else np.zeros((0, 3))
        return Configuration(twin, coords, centres, R)

    def jac(self, t: float, y: FloatArray) -> Any:
        """The Jacobian ``d(dy/dt)/dy`` as a scipy.sparse CSC matrix (untyped: Any; see the module docstring)."""
        n = self.n
        x, v = y[:n], y[n:]
        twin = self.statics_twin(t)
        config = self.configuration(x, twin)
        K = tangent_stiffness(twin, config, sparse=True)
        chart = sp.identity(n, format="lil")
        Tinv = sp.identity(n, format="lil")
        if self.nb:
            rot = self.lay.body_dof[:, None] + 3 + np.arange(3)[None, :]
            Jl = left_jacobian(x[rot])
            Jli = left_jacobian_inverse(x[rot])
            for k in range(self.nb):
                idx = rot[k]
                chart[np.ix_(idx, idx)] = Jl[k]
                Tinv[np.ix_(idx, idx)] = Jli[k]
        D = sp.csr_matrix((n, n))
        if self.c_damp is not None:
            coords = config.coords
            A = equilibrium_matrix(twin, config, sparse=True)
            _, _, _, taut = self.member_state(t, coords, np.zeros_like(coords))
            D = A @ sp.diags(np.where(taut, self.c_damp, 0.0)) @ A.T
        Minv, G = self._inverse_mass_and_gyro(x, v)
        Jxv = Tinv.tocsr()
        Jvx = -(Minv @ K @ chart.tocsr())
        Jvv = -(Minv @ (D + G))
        return sp.bmat([[None, Jxv], [Jvx, Jvv]], format="csc")

    def _inverse_mass_and_gyro(self, x: FloatArray, v: FloatArray) -> tuple[Any, Any]:
        """``(M^-1, G_gyro)`` as scipy.sparse CSR matrices (untyped: Any)."""
        n = self.n
        blocks_inv = sp.lil_matrix((n, n))
        G = sp.lil_matrix((n, n))
        diag = np.zeros(n)
        diag[:self.n_free] = 1.0 / self.masses.free
        blocks_inv.setdiag(diag)
        if self.nb:
            _, _, R = self.placement(x)
            Mb, _, s, Ic, w = self.body_matrices(R, v)
            Mbi = np.linalg.inv(Mb)
            for k in range(self.nb):
                idx = self.lay.body_dof[k] + np.arange(6)
                blocks_inv[np.ix_(idx, idx)] = Mbi[k]
                # d/domega of [omega x (omega x s); omega x (I omega)]
                g = np.zeros((6, 6))
                ws = cross(w[k], s[k])
                g[:3, 3:] = -hat(ws) - hat(w[k]) @ hat(s[k])
                g[3:, 3:] = hat(w[k]) @ Ic[k] - hat(Ic[k] @ w[k])
                G[np.ix_(idx, idx)] = g
        return blocks_inv.tocsr(), G.tocsr()

    # -- stepper hooks ------------------------------------------------------------------------------
    def events(self) -> list[StateEvent]:
        """No state events: members are smooth (strings' slackening is a kink the adaptive
        step control resolves)."""
        return []

    def handle_event(self, event: StateEvent, t: float, y: FloatArray) -> tuple[FloatArray, GeneralSystem]:
        """There are no state events (:meth:`events`): the state and the model as they are."""
        return np.asarray(y, dtype=float), self

    def after_step(self, t: float, y: FloatArray) -> tuple[FloatArray, GeneralSystem] | None:
        """Re-anchor rotation charts whose angle exceeds :data:`RECHART_ANGLE`: the state and the
        model of the new charts, or None."""
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
        return y, self.with_chart(R_ref)

    def kinetic_energy(self, x: FloatArray, v: FloatArray) -> float:
        T = 0.5 * float(np.sum(self.masses.free * v[:self.n_free] ** 2))
        if self.nb:
            _, _, R = self.placement(x)
            Mb, _, _, _, _ = self.body_matrices(R, v)
            vb = v[self.lay.body_dof[:, None] + np.arange(6)[None, :]]
            T += 0.5 * float(np.einsum("ki,kij,kj->", vb, Mb, vb))
        return T
