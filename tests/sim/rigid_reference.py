"""An independent reference for general structures of free rigid bodies and point masses.

Written for the tests from the physics alone, sharing nothing with the simulator: each body
is integrated about its centre of mass with its rotation matrix ``R`` as a state
(``dR/dt = hat(omega) R``, no rotation vector, so no chart to re-anchor) and Euler's
equations ``I w' + w x I w = M`` in the world frame; free nodes are particles. Members are
axial springs ``t = EA (l - l0)/l0`` plus ``c dl/dt`` (strings only while taut: ``l >= l0``).
Masses are lumped as the docs define them (``docs/scenes.md``): a node carries its point mass
and half of each attached member's mass, a body's mass is shared equally by its nodes.
No gravity, no loads, no supports: the bodies and nodes float.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def _cross(a, b):
    """``a x b`` over the last axis of 3-vectors: ``np.cross`` spends ten times longer on its
    axis handling than on the products for these small arrays, and the integration calls it
    ~10^4 times per run."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(a.shape if a.ndim >= b.ndim else b.shape)     # (k, 3) with (k, 3) or (3,)
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


class FloatingReference:
    """The floating structure ``s`` (a ``Structure``) with member damping ``c`` (m,) or None."""

    def __init__(self, s, c=None):
        self.s = s
        m = s.node_masses.astype(float).copy()
        np.add.at(m, s.members[:, 0], 0.5 * s.member_masses)
        np.add.at(m, s.members[:, 1], 0.5 * s.member_masses)
        for body in s.bodies:
            m[list(body.nodes)] += body.mass / len(body.nodes)
        self.m = m
        self.bodies = [np.array(b.nodes) for b in s.bodies]
        in_body = np.zeros(s.n_nodes, bool)
        for idx in self.bodies:
            in_body[idx] = True
        self.particles = np.flatnonzero(~in_body)
        self.c = c
        # member k pulls node a toward b with t u and b toward a: node forces are -incidence.T @ (t u)
        self.incidence = np.zeros((len(s.members), s.n_nodes))
        self.incidence[np.arange(len(s.members)), s.members[:, 0]] = -1.0
        self.incidence[np.arange(len(s.members)), s.members[:, 1]] = 1.0

    def initial(self, nodes, node_velocities):
        """The reference state of nodes (n, 3) moving rigidly with ``node_velocities`` (n, 3)."""
        self.p = []                 # body-frame offsets from the centre of mass (R = I at t = 0)
        self.inertia = []           # body frame: the world frame's is R I R^T
        self.inverse_inertia = []   # and its inverse R I^-1 R^T
        parts = []
        for idx in self.bodies:
            mk = self.m[idx]
            M = mk.sum()
            cm = mk @ nodes[idx] / M
            vcm = mk @ node_velocities[idx] / M
            r = nodes[idx] - cm
            I = np.einsum("k,kij->ij", mk, np.einsum("ki,ki->k", r, r)[:, None, None] * np.eye(3)
                          - np.einsum("ki,kj->kij", r, r))
            L = np.einsum("k,ki->i", mk, _cross(r, node_velocities[idx] - vcm))
            w = np.linalg.solve(I, L)
            self.p.append(r)
            self.inertia.append(I)
            self.inverse_inertia.append(np.linalg.inv(I))
            parts += [cm, vcm, np.eye(3).ravel(), w]
        parts += [nodes[self.particles].ravel(), node_velocities[self.particles].ravel()]
        return np.concatenate(parts)

    def unpack(self, y):
        """Node positions and velocities (n, 3) of a reference state."""
        s = self.s
        x = np.zeros((s.n_nodes, 3))
        v = np.zeros((s.n_nodes, 3))
        o = 0
        for b, idx in enumerate(self.bodies):
            cm, vcm, R, w = y[o:o + 3], y[o + 3:o + 6], y[o + 6:o + 15].reshape(3, 3), y[o + 15:o + 18]
            r = self.p[b] @ R.T
            x[idx] = cm + r
            v[idx] = vcm + _cross(w, r)
            o += 18
        n = len(self.particles)
        x[self.particles] = y[o:o + 3 * n].reshape(n, 3)
        v[self.particles] = y[o + 3 * n:o + 6 * n].reshape(n, 3)
        return x, v

    def node_forces(self, x, v):
        s = self.s
        a, b = s.members[:, 0], s.members[:, 1]
        h = x[b] - x[a]
        l = np.linalg.norm(h, axis=1)
        u = h / l[:, None]
        t = s.EA * (l - s.rest_lengths) / s.rest_lengths
        if self.c is not None:
            t = t + self.c * np.einsum("ij,ij->i", u, v[b] - v[a])
        t = np.where(s.is_string & (l < s.rest_lengths), 0.0, t)
        return -self.incidence.T @ (t[:, None] * u)

    def rhs(self, t, y):
        x, v = self.unpack(y)
        f = self.node_forces(x, v)
        out = np.zeros_like(y)
        o = 0
        for b, idx in enumerate(self.bodies):
            R, w = y[o + 6:o + 15].reshape(3, 3), y[o + 15:o + 18]
            M = self.m[idx].sum()
            cm = y[o:o + 3]
            torque = _cross(x[idx] - cm, f[idx]).sum(axis=0)
            out[o:o + 3] = y[o + 3:o + 6]
            out[o + 3:o + 6] = f[idx].sum(axis=0) / M
            out[o + 6:o + 15] = (_hat(w) @ R).ravel()
            # Euler: w' = I^-1 (M - w x I w) in the world frame, I = R I_body R^T
            w_body = R.T @ w
            spin = _cross(w, R @ (self.inertia[b] @ w_body))
            out[o + 15:o + 18] = R @ (self.inverse_inertia[b] @ (R.T @ (torque - spin)))
            o += 18
        n = len(self.particles)
        out[o:o + 3 * n] = v[self.particles].ravel()
        out[o + 3 * n:o + 6 * n] = (f[self.particles] / self.m[self.particles, None]).ravel()
        return out

    def run(self, nodes, node_velocities, times, rtol=1e-12, atol=1e-13):
        """Node positions (len(times), n, 3) from the given start (DOP853, tight tolerances)."""
        y0 = self.initial(nodes, node_velocities)
        sol = solve_ivp(self.rhs, (times[0], times[-1]), y0, method="DOP853", t_eval=times, rtol=rtol, atol=atol)
        assert sol.success, sol.message
        return np.array([self.unpack(y)[0] for y in sol.y.T])
