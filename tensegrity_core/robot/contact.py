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

**Rolling and spin resistance** (MuJoCo's ``condim="6"``). A cap pressed with ``F_n``
resists turning on the floor with a couple: the rolling part opposes the body's angular
velocity in the floor plane, ``w_t = w - (w . n) n``, the spin part its component about the
normal, ``w_n = w . n`` (the floor does not move, so ``w`` is the cap's angular velocity
relative to it)::

    M = -b_r F_n w_t / max(|w_t|, w_s) - b_s F_n w_n n / max(|w_n|, w_s)

with lever arms ``b_r`` (rolling friction) and ``b_s`` (torsional friction) [m]: MuJoCo's
rolling and torsional friction coefficients, which also limit its couples to ``b F_n``.
A rolling resistance coefficient ``C_rr`` (force per normal force) of a wheel of radius
``r`` is ``b_r = C_rr r``. Like the tangential friction's anchor stiffness, the
regularisation is a chosen number that a fixed 1 kHz step resolves: below the spin rate
``w_s`` (:data:`SPIN_TOLERANCE`) the couple is a rotational damper ``b F_n / w_s``, above it
the full Coulomb couple. **Energy**: the couple's power ``M . w = -b_r F_n |w_t|^2 / max(..)
- b_s F_n w_n^2 / max(..) <= 0``: it only ever takes energy out, and stores none.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

#: The spin rate ``w_s`` [rad/s] below which the rolling and spin couples fall linearly to
#: zero (module docstring). A cap under ``F_n`` = 2 kN with ``b`` = 1 mm then damps at
#: ``b F_n / w_s`` = 4 N m s, resolved by a 1 ms explicit step on a body whose inertia about
#: the axis exceeds ~2 g m^2 (the rods' axial inertias: 3-bar 2.9 g m^2, 6-bar 3.4 g m^2).
SPIN_TOLERANCE = 0.5


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


def resisting_couple(w: ArrayLike, F_n: ArrayLike, normal: ArrayLike, rolling: float,
                     torsional: float) -> FloatArray:
    """The rolling and spin resistance couples ``M`` (..., 3) [N m] (module docstring) of caps
    on bodies turning at ``w`` (..., 3) [rad/s] (world frame) pressed with ``F_n`` (...,) [N]
    on the floor of unit ``normal`` (3,), lever arms ``rolling`` and ``torsional`` [m]."""
    W = np.asarray(w, dtype=float)
    n = np.asarray(normal, dtype=float)
    Fn = np.asarray(F_n, dtype=float)
    wn = W @ n
    wt = W - wn[..., None] * n
    size = np.sqrt(np.sum(wt * wt, axis=-1))
    roll = -rolling * Fn / np.maximum(size, SPIN_TOLERANCE)
    spin = -torsional * Fn * wn / np.maximum(np.abs(wn), SPIN_TOLERANCE)
    out: FloatArray = roll[..., None] * wt + spin[..., None] * n
    return out
