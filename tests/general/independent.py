"""Independent computations for checking form-finding: written out here from the plain
equilibrium equations of structures without rigid bodies (free node coordinates, member
forces ``t = EA (l - l0)/l0``, slack strings 0, dead loads), sharing no code with
``tensegrity_core`` beyond the structure's arrays.

- :func:`net_forces`: the net force on every node [N];
- :func:`relative_residual`: per free node, the net force on its free axes over the
  forces that meet there (``sum |t| + |load|``);
- :func:`plain_newton`: a plain Newton iteration (full steps, no shift, no line search)
  with the analytic Jacobian assembled here, in double precision;
- :func:`mp_equilibrium`: Newton in ``digits`` decimal digits (mpmath), to polish a start
  into the exact root of the equations.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np

from tensegrity_core.general import Structure


def member_forces(s: Structure, x: np.ndarray) -> np.ndarray:
    """Tension-positive member forces [N] at node coordinates ``x`` (n, 3)."""
    l = np.linalg.norm(x[s.members[:, 1]] - x[s.members[:, 0]], axis=1)
    t = s.EA * (l - s.rest_lengths) / s.rest_lengths
    return np.where(s.is_string & (t < 0), 0.0, t)


def net_forces(s: Structure, x: np.ndarray) -> np.ndarray:
    """(n, 3) net force on every node [N]: members pulling with ``t`` along themselves, loads."""
    h = x[s.members[:, 1]] - x[s.members[:, 0]]
    pull = (member_forces(s, x) / np.linalg.norm(h, axis=1))[:, None] * h
    f = s.loads + s.node_masses[:, None] * s.gravity
    np.add.at(f, s.members[:, 0], pull)
    np.add.at(f, s.members[:, 1], -pull)
    return f


def relative_residual(s: Structure, x: np.ndarray) -> np.ndarray:
    """Per node with a free axis: |net force on its free axes| / (sum |t| + |load|) (0 where
    nothing meets), in node order."""
    assert not s.bodies, "rigid bodies are not covered by these plain equations"
    t = np.abs(member_forces(s, x))
    scale = np.linalg.norm(s.loads, axis=1) + np.bincount(s.members.ravel(), np.repeat(t, 2), s.n_nodes)
    net = np.linalg.norm(np.where(s.pinned, 0.0, net_forces(s, x)), axis=1)
    free = ~s.pinned.all(axis=1)
    return np.divide(net, scale, out=np.zeros(s.n_nodes), where=scale > 0)[free]


def _jacobian(s: Structure, x: np.ndarray) -> np.ndarray:
    """d(net force)/dx over all 3n coordinates: per member ``k u u^T + t/l (I - u u^T)``."""
    n = s.n_nodes
    J = np.zeros((3 * n, 3 * n))
    t = member_forces(s, x)
    for i, (a, b) in enumerate(s.members):
        h = x[b] - x[a]
        l = np.linalg.norm(h)
        u = h / l
        k = 0.0 if (s.is_string[i] and t[i] == 0.0) else s.EA[i] / s.rest_lengths[i]
        block = k * np.outer(u, u) + t[i] / l * (np.eye(3) - np.outer(u, u))
        for p, q, sign in ((a, a, -1), (b, b, -1), (a, b, 1), (b, a, 1)):
            J[3 * p:3 * p + 3, 3 * q:3 * q + 3] += sign * block
    return J


def plain_newton(s: Structure, x0: np.ndarray, tol: float, max_iter: int = 100) -> tuple[np.ndarray, int]:
    """Full Newton steps on the free coordinates from ``x0`` until every free node's relative
    residual is <= ``tol`` or the step no longer changes anything; returns (x, iterations)."""
    free = ~s.pinned.ravel()
    x = np.array(x0, dtype=float)
    for it in range(max_iter + 1):
        if relative_residual(s, x).max(initial=0.0) <= tol:
            return x, it
        F = net_forces(s, x).ravel()[free]
        J = _jacobian(s, x)[np.ix_(free, free)]
        step = np.linalg.solve(J, -F)
        flat = x.ravel()
        flat[free] += step
        x = flat.reshape(-1, 3)
        if np.abs(step).max() <= 4 * np.finfo(float).eps * np.abs(x).max():
            return x, it + 1
    raise AssertionError(f"plain Newton did not converge in {max_iter} iterations")


def mp_equilibrium(s: Structure, x0: np.ndarray, digits: int = 40, iterations: int = 8) -> np.ndarray:
    """The root of the equilibrium equations near ``x0`` by Newton in ``digits`` digits
    (analytic Jacobian in mpmath; float inputs converted exactly), rounded to doubles."""
    free = [(j, c) for j in range(s.n_nodes) for c in range(3) if not s.pinned[j, c]]
    with mp.workdps(digits):
        X = [[mp.mpf(float(v)) for v in row] for row in x0]
        l0 = [mp.mpf(float(v)) for v in s.rest_lengths]
        EA = [mp.mpf(float(v)) for v in s.EA]
        loads = [[mp.mpf(float(v)) for v in row] for row in s.loads]
        index = {jc: k for k, jc in enumerate(free)}
        for _ in range(iterations):
            F = mp.matrix(len(free), 1)
            J = mp.matrix(len(free), len(free))
            for (j, c), k in index.items():
                F[k] = loads[j][c]
            for i, (a, b) in enumerate(s.members):
                h = [X[b][c] - X[a][c] for c in range(3)]
                l = mp.sqrt(sum(v * v for v in h))
                t = EA[i] * (l - l0[i]) / l0[i]
                slack = bool(s.is_string[i]) and t < 0
                t = mp.mpf(0) if slack else t
                k_ax = mp.mpf(0) if slack else EA[i] / l0[i]
                u = [v / l for v in h]
                for c in range(3):
                    if (a, c) in index:
                        F[index[(a, c)]] += t * u[c]
                    if (b, c) in index:
                        F[index[(b, c)]] -= t * u[c]
                for c in range(3):
                    for e in range(3):
                        block = k_ax * u[c] * u[e] + t / l * ((1 if c == e else 0) - u[c] * u[e])
                        for p, q, sign in ((a, a, -1), (b, b, -1), (a, b, 1), (b, a, 1)):
                            if (p, c) in index and (q, e) in index:
                                J[index[(p, c)], index[(q, e)]] += sign * block
            step = mp.lu_solve(J, -F)
            for (j, c), k in index.items():
                X[j][c] += step[k]
        return np.array([[float(v) for v in row] for row in X])
