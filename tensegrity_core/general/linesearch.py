"""The line search of form-finding's Newton steps (the paper's Eqs. 83-84): the step factor
``x`` that minimises the total potential energy ``V(U + x dU)``, from forces where it can
(the slope ``phi'(x) = -P(x) . dU`` is free of the round-off of energy differences)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq, minimize_scalar

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.statics import generalized_force, potential_energy
from tensegrity_core.general.structure import Structure

FloatArray = NDArray[np.float64]


def energy_noise(V: float) -> float:
    """Energy differences below this are rounding [J]."""
    return 1e-12 * max(abs(V), 1e-300)


def line_search(structure: Structure, config: Configuration, dU: FloatArray, V0: float,
                P0: FloatArray, *, x_max: float = 1.0) -> tuple[float, float, Configuration]:
    """Bounded line search of Eqs. 83-84: ``x`` minimising ``V(U + x dU)`` on ``[0, 1]``.

    The full step is taken when the potential has not risen and its slope there is
    non-negative-descent or small (``|phi'(1)| <= 0.01 |phi'(0)|``, the Newton regime, so
    convergence stays quadratic); otherwise the slope ``phi'(x) = -P(x) . dU`` (computed
    from forces, free of the round-off of energy differences) is driven to zero by Brent's
    method when it changes sign on ``[0, 1]``, and ``V`` itself is minimised by bounded
    Brent (MATLAB's ``fminbnd``) when it does not. With ``x_max > 1`` (a step along negative
    curvature) a full step that still descends steeply is extended, doubling ``x`` up to
    ``x_max`` while ``V`` falls, to the root of the slope past it. Returns ``(x, V(x),
    configuration)``; ``x = 0`` when no decrease was found.
    """
    slope0 = -float(np.dot(P0, dU))
    noise = energy_noise(V0)
    # the configuration and the energy at each x, each computed once and only when asked for:
    # Brent's root of the slope needs no energy until its end (a third of a step's cost)
    configs: dict[float, Configuration] = {}
    energies: dict[float, float] = {}

    def at(x: float) -> Configuration:
        if x not in configs:
            configs[x] = config.retract(x * dU)
        return configs[x]

    def phi(x: float) -> float:
        if x not in energies:
            v = potential_energy(structure, at(x).coords)
            energies[x] = v if np.isfinite(v) else np.inf
        return energies[x]

    def slope(x: float) -> float:
        return -float(np.dot(generalized_force(structure, at(x)), dU))

    if slope0 >= 0:            # not a descent direction (cannot happen with a PD shift)
        return 0.0, V0, config
    V1 = phi(1.0)
    if np.isfinite(V1):
        s1 = slope(1.0)
        if np.isfinite(s1) and V1 <= V0 + noise and (s1 <= 0 or abs(s1) <= 0.01 * abs(slope0)):
            if x_max > 1.0 and s1 < -0.01 * abs(slope0):
                x = _extend(phi, slope, x_max)
                return x, energies[x], configs[x]
            return 1.0, V1, configs[1.0]
        if np.isfinite(s1) and s1 > 0:
            x = float(brentq(slope, 0.0, 1.0, xtol=1e-10, rtol=1e-6, maxiter=100))
            if phi(x) < V0:
                return x, energies[x], configs[x]
    res = minimize_scalar(phi, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-8})
    x = float(res.x)
    if phi(x) < V0:
        return x, energies[x], configs[x]
    x = 1.0
    for _ in range(60):
        x *= 0.5
        if phi(x) < V0:
            return x, energies[x], configs[x]
    return 0.0, V0, config


def _extend(phi: Callable[[float], float], slope: Callable[[float], float], x_max: float) -> float:
    """Past ``x = 1`` (descending there) along negative curvature: double ``x`` while ``V``
    falls and the slope stays negative, up to ``x_max``; then the root of the slope in the
    last interval if it changed sign. Returns the ``x`` of the lowest ``V`` found."""
    prev, x = 1.0, min(2.0, x_max)
    while np.isfinite(phi(x)) and phi(x) < phi(prev) and slope(x) < 0 and x < x_max:
        prev, x = x, min(2.0 * x, x_max)
    if np.isfinite(phi(x)) and phi(x) < phi(prev) and slope(x) >= 0 > slope(prev):
        root = float(brentq(slope, prev, x, xtol=1e-10, rtol=1e-6, maxiter=100))
        return min((prev, root, x), key=phi)
    if np.isfinite(phi(x)) and phi(x) < phi(prev):
        return x
    if slope(prev) < 0 <= slope(x):
        root = float(brentq(slope, prev, x, xtol=1e-10, rtol=1e-6, maxiter=100))
        return min((prev, root), key=phi)
    return prev
