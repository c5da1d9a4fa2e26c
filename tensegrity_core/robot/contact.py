"""Normal contact of end caps (spheres) with a floor plane, possibly inclined.

The floor is the plane through ``point`` with unit normal ``normal`` (pointing out of the
ground, into the free space). A cap of radius ``r`` centred at ``x`` penetrates by
``delta = r - normal . (x - point)`` [m] (contact while ``delta > 0``); its contact point
is ``x - r normal`` and it penetrates at the rate ``deltadot = -normal . v`` [m/s] (the
spin of the cap moves the contact point only tangentially).

**Normal force** (compliant, Hunt-Crossley with a linear spring, as Drake's compliant
point contact)::

    F_n = k delta max(0, 1 + d deltadot)      (delta > 0; 0 otherwise)

with stiffness ``k`` [N/m] and dissipation ``d`` [s/m]. It acts along ``normal`` on the
cap, so it only ever pushes (``F_n >= 0``). It is continuous at touch-down (``delta = 0``)
whatever the speed, unlike a linear spring-damper that jumps to ``c deltadot``; at rest it
is the spring, so a cap carrying ``W`` sinks ``W / k`` (docs/robots.md chooses ``k`` so that
this stays below 1 mm).

**Energy.** With ``V = k delta^2 / 2`` stored, the contact's power into the body is
``-F_n deltadot``, so ``dV/dt - F_n deltadot = (k delta - F_n) deltadot``: equal to
``-k d delta deltadot^2 <= 0`` while ``1 + d deltadot > 0``, and to ``k delta deltadot < 0``
when the clamp acts (``deltadot < -1/d``: separating fast, the force is zero rather than
pulling). The contact never adds energy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def penetration(x: ArrayLike, v: ArrayLike, radius: ArrayLike, normal: ArrayLike,
                point: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(delta (n,) [m], deltadot (n,) [m/s])`` of caps centred at ``x`` (n, 3) moving at
    ``v`` (n, 3), ``radius`` [m], against the plane (``normal`` (3,) unit, ``point`` (3,))."""
    n = np.asarray(normal, dtype=float)
    height = (np.asarray(x, dtype=float) - np.asarray(point, dtype=float)) @ n
    delta: FloatArray = np.asarray(radius, dtype=float) - height
    rate: FloatArray = -(np.asarray(v, dtype=float) @ n)
    return delta, rate


def normal_force(delta: ArrayLike, deltadot: ArrayLike, k: ArrayLike, d: ArrayLike) -> FloatArray:
    """Normal forces ``F_n = k delta max(0, 1 + d deltadot)`` [N] where ``delta > 0``, else 0
    (module docstring)."""
    D = np.asarray(delta, dtype=float)
    out: FloatArray = np.where(D > 0.0, np.asarray(k, dtype=float) * D
                               * np.maximum(0.0, 1.0 + np.asarray(d, dtype=float) * np.asarray(deltadot, dtype=float)),
                               0.0)
    return out


def normal_force_derivatives(delta: ArrayLike, deltadot: ArrayLike, k: ArrayLike,
                             d: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(dF_n/d delta [N/m], dF_n/d deltadot [N s/m])`` of :func:`normal_force` where it is
    smooth (zero out of contact and where the clamp acts)."""
    D = np.asarray(delta, dtype=float)
    K = np.asarray(k, dtype=float)
    dd = np.asarray(d, dtype=float)
    factor = 1.0 + dd * np.asarray(deltadot, dtype=float)
    active = (D > 0.0) & (factor > 0.0)
    by_delta: FloatArray = np.where(active, K * factor, 0.0)
    by_rate: FloatArray = np.where(active, K * D * dd, 0.0)
    return by_delta, by_rate


def contact_energy(delta: ArrayLike, k: ArrayLike) -> FloatArray:
    """Elastic energy ``k max(0, delta)^2 / 2`` [J] stored in each contact."""
    D = np.maximum(np.asarray(delta, dtype=float), 0.0)
    out: FloatArray = 0.5 * np.asarray(k, dtype=float) * D * D
    return out


def floor_normal(incline: float = 0.0, heading: float = 0.0) -> FloatArray:
    """The unit normal of a floor rising at ``incline`` [rad] towards the horizontal
    direction ``heading`` [rad, from +x towards +y]: ``(-sin i cos h, -sin i sin h, cos i)``."""
    s, c = np.sin(incline), np.cos(incline)
    return np.array([-s * np.cos(heading), -s * np.sin(heading), c])
