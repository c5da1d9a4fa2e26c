"""The singular sets near one equilibrium of the class-2 mechanism, with their distances.

:func:`classify_singularities` reports every singular set (the actuator-plane sets of
:mod:`~tensegrity_core.class2.singularities.distances` and the quantities that vanish on
them at the equilibrium: beta, the Jacobian ``dD/drho``, the IK discriminant), nearest
first. It needs the forward kinematics, which itself needs the distances (to refuse inputs
on a set): so the report lives in this module and the distances in their own, and
:mod:`~tensegrity_core.class2.kinematics` imports only the latter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.kinematics import forward_kinematics, jacobian_D_rho
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.class2.singularities.distances import singularity_distances
from tensegrity_core.errors import SingularityError


@dataclass(frozen=True)
class SingularSet:
    """One singular set near a configuration.

    ``distance`` is the distance in the actuator plane divided by L (dimensionless, 0 on
    the set, negative outside the domain across it); ``value`` is the quantity that
    vanishes on the set (see ``description``), in ``unit``: ``rad``, ``m/m`` (the
    determinant of ``dD/drho``), ``N^4 m^2`` (the IK discriminant, stiffnesses in N/m), or
    ``L`` / ``2L`` for a length given as a multiple of the strut length (or twice it).
    """

    kind: str
    distance: float
    value: float
    unit: str
    description: str


@dataclass(frozen=True)
class SingularityReport:
    """Every singular set with its distance from ``(rho1, rho2)``, nearest first.

    ``jacobian`` is ``dD/drho`` at the equilibrium (None on lambda1 = 0, where it is
    unbounded), ``jacobian_cond`` its 2-norm condition number (inf when singular).
    """

    rho1: float
    rho2: float
    beta: float
    x: float
    y: float
    sets: tuple[SingularSet, ...]
    jacobian: NDArray[np.float64] | None
    jacobian_det: float
    jacobian_cond: float

    @property
    def nearest(self) -> SingularSet:
        return self.sets[0]

    @property
    def distance(self) -> float:
        """Distance to the nearest singular set (dimensionless)."""
        return self.sets[0].distance

    def near(self, threshold: float) -> tuple[SingularSet, ...]:
        """The sets closer than ``threshold`` (dimensionless)."""
        return tuple(s for s in self.sets if s.distance <= threshold)

    def as_dict(self) -> dict[str, Any]:
        return {
            "rho1": self.rho1, "rho2": self.rho2, "beta": self.beta, "x": self.x, "y": self.y,
            "sets": [s.__dict__ for s in self.sets],
            "jacobian": None if self.jacobian is None else self.jacobian.tolist(),
            "jacobian_det": self.jacobian_det, "jacobian_cond": self.jacobian_cond,
        }


def classify_singularities(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> SingularityReport:
    """The singular sets near the equilibrium of ``(rho1, rho2)`` [m], with distances.

    Sets (see :mod:`tensegrity_core.class2.singularities` for the distance formulas):
    ``lambda1`` (rho1 + rho2 -> 2L; value lambda1 / 2L), ``beta_zero`` (beta -> 0, the same
    set on the equilibrium manifold; value beta), ``lambda2`` (rho1 -> L; value lambda2 / L),
    ``beta_half_pi`` (beta -> pi/2; value pi/2 - beta), ``ik_discriminant`` (the discriminant
    ``xi1^2 - 4 xi2 xi0`` of Eq. 18 at the configuration's own target and branch; it equals
    ``4 k2^2 (L cos beta)^2 Q^2`` and vanishes on the beta_half_pi line), ``det_jacobian``
    (``det dD/drho = L cos(beta) dbeta/drho2``, zero on the same line, unbounded at lambda1 = 0)
    and ``folded`` (rho1 = rho2 = 0; value sqrt(rho1^2 + rho2^2) / L).
    Raises :class:`DomainError` outside the configuration domain.
    """
    fk = forward_kinematics(rho1, rho2, params)
    r1, r2, L, k2 = fk.rho1, fk.rho2, params.L, params.k2
    K = 2.0 * params.k3 + k2
    dist = singularity_distances(r1, r2, params)
    c, y = fk.x - r1, fk.y
    xi0 = k2**2 * (y**2 * r1**2 - c**2 * (4 * L**2 - r1**2))
    xi1 = 2 * k2 * r1 * (k2 * c**2 - K * y**2)
    xi2 = y**2 * K**2 + k2**2 * c**2
    try:
        jac = jacobian_D_rho(r1, r2, params)
        det, cond = float(np.linalg.det(jac)), float(np.linalg.cond(jac))
    except SingularityError:
        jac, det, cond = None, math.inf, math.inf
    lam1 = math.sqrt(max(0.0, (2 * L - r1 - r2) * (2 * L + r1 + r2)))
    sets = [
        SingularSet("lambda1", dist["lambda1"], lam1 / (2 * L), "2L",
                    "rho1 + rho2 -> 2L: struts AE, CE flat, D on the X axis, |dD/drho| unbounded"),
        SingularSet("beta_zero", dist["lambda1"], fk.beta, "rad",
                    "beta -> 0 (paper's range limit); on the equilibrium manifold only at lambda1 = 0"),
        SingularSet("lambda2", dist["lambda2"], math.sqrt(max(0.0, (L - r1) * (L + r1))) / L, "L",
                    "rho1 -> L: F reaches A, its speed rho1 rho1' / lambda2 unbounded"),
        SingularSet("beta_half_pi", dist["beta_half_pi"], 0.5 * math.pi - fk.beta, "rad",
                    "beta -> pi/2 (paper's range limit): D straight above B, y = L is a fold"),
        SingularSet("ik_discriminant", dist["beta_half_pi"], xi1**2 - 4 * xi2 * xi0, "N^4 m^2",
                    "xi1^2 - 4 xi2 xi0 -> 0 (Eq. 18): the IK roots merge (same line as beta = pi/2)"),
        SingularSet("det_jacobian", dist["beta_half_pi"], det, "m/m",
                    "det dD/drho = L cos(beta) dbeta/drho2 -> 0 (same line as beta = pi/2)"),
        SingularSet("folded", dist["folded"], dist["folded"], "L",
                    "rho1 = rho2 = 0: every node on the Y axis (on the beta = pi/2 line)"),
    ]
    sets.sort(key=lambda s: s.distance)
    return SingularityReport(r1, r2, fk.beta, fk.x, fk.y, tuple(sets), jac, det, cond)
