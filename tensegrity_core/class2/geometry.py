"""Geometry of the class-2 mechanism: node positions and member lengths from q.

Frame and conventions (the paper's Fig. 1): the mechanism lies in the horizontal X-Y
plane; node A is fixed at the origin; B and C slide on the X axis, F on the Y axis.
Generalised coordinates ``q = (rho1, rho2, beta)``:

- ``rho1 = |AB|``, ``rho2 = |BC|`` actuator lengths [m], both >= 0;
- ``beta`` angle of strut BD from the +X axis [rad], counter-clockwise;
- ``alpha`` (dependent) angle of strut AE from +X: ``cos(alpha) = (rho1 + rho2) / (2 L)``
  with ``0 <= alpha <= pi/2`` (Eq. 1).

Node positions (Eq. 2, with ``lambda1 = sqrt(4L^2 - (rho1+rho2)^2)`` and
``lambda2 = sqrt(L^2 - rho1^2)``)::

    A = (0, 0)            B = (rho1, 0)             C = (rho1 + rho2, 0)
    D = B + L (cos beta, sin beta)                  E = ((rho1+rho2)/2, lambda1/2)
    F = (0, lambda2)

The configuration exists for ``rho1, rho2 >= 0``, ``rho1 <= L`` (F exists) and
``rho1 + rho2 <= 2L`` (E exists). Functions accept scalars or broadcastable arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.params import Class2Params
from tensegrity_core.errors import DomainError

NODE_NAMES: Final = ("A", "B", "C", "D", "E", "F")


@dataclass(frozen=True)
class Member:
    """One member of the mechanism, numbered as in the paper."""

    number: int        # 1..10, the paper's numbering
    name: str          # node pair, e.g. "AB"
    kind: str          # "actuator" | "spring" | "strut"
    stiffness: str     # name of the Class2Params attribute giving its axial stiffness
    damping: str | None  # name of the damping attribute (springs only)

    @property
    def nodes(self) -> tuple[int, int]:
        """Indices into :data:`NODE_NAMES` of the member's two end nodes."""
        return NODE_NAMES.index(self.name[0]), NODE_NAMES.index(self.name[1])

    @property
    def label(self) -> str:
        return f"{self.number}_{self.name}"


MEMBERS: Final[tuple[Member, ...]] = (
    Member(1, "AB", "actuator", "ka", None),
    Member(2, "BC", "actuator", "ka", None),
    Member(3, "CD", "spring", "k3", "c3"),
    Member(4, "DE", "spring", "k2", "c2"),
    Member(5, "AE", "strut", "kb", None),
    Member(6, "BF", "strut", "kb", None),
    Member(7, "EF", "spring", "k1", "c1"),
    Member(8, "BE", "spring", "k4", "c4"),
    Member(9, "BD", "strut", "kb", None),
    Member(10, "CE", "strut", "kb", None),
)
SPRINGS: Final = tuple(m for m in MEMBERS if m.kind == "spring")


def check_actuator_lengths(rho1: float, rho2: float, L: float) -> None:
    """Raise :class:`DomainError` unless the configuration exists (scalars only)."""
    for name, v in (("rho1", rho1), ("rho2", rho2)):
        if not math.isfinite(v):
            raise DomainError(f"{name} must be finite, got {v!r}")
        if v < 0.0:
            raise DomainError(f"actuator length {name} = {v:g} m is negative", distance=-v)
    if rho1 > L:
        raise DomainError(
            f"rho1 = {rho1:g} m exceeds the strut length L = {L:g} m: node F cannot reach the "
            f"Y axis (rho1 - L = {rho1 - L:.3g} m)",
            distance=rho1 - L,
        )
    if rho1 + rho2 > 2.0 * L:
        raise DomainError(
            f"rho1 + rho2 = {rho1 + rho2:g} m exceeds 2L = {2 * L:g} m: struts AE and CE cannot "
            f"meet at E (excess {rho1 + rho2 - 2 * L:.3g} m)",
            distance=rho1 + rho2 - 2.0 * L,
        )


def lambdas(rho1: ArrayLike, rho2: ArrayLike, L: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(lambda1, lambda2) = (sqrt(4L^2 - (rho1+rho2)^2), sqrt(L^2 - rho1^2))`` (Eq. A.15).

    Written as products of sums and differences to avoid cancellation near the singular
    sets ``rho1 + rho2 = 2L`` (lambda1 = 0) and ``rho1 = L`` (lambda2 = 0).
    """
    s: NDArray[np.float64] = np.add(rho1, rho2)
    lam1 = np.sqrt((2.0 * L - s) * (2.0 * L + s))
    lam2 = np.sqrt((L - np.asarray(rho1)) * (L + np.asarray(rho1)))
    return lam1, lam2


def end_effector_of(q: ArrayLike, L: float) -> tuple[float, float]:
    """Node D = B + L (cos beta, sin beta) [m] of one configuration ``q = (rho1, rho2, beta)``
    (the measured state's D: beta as given, not re-solved from the lengths)."""
    rho1, beta = float(np.asarray(q, dtype=float)[0]), float(np.asarray(q, dtype=float)[2])
    return rho1 + L * math.cos(beta), L * math.sin(beta)


def node_positions(q: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """Node coordinates, shape ``q.shape[:-1] + (6, 2)``, rows in the order A..F [m].

    ``q`` is ``(rho1, rho2, beta)`` or an array with that trailing dimension.
    """
    qa = np.asarray(q, dtype=np.float64)
    rho1, rho2, beta = qa[..., 0], qa[..., 1], qa[..., 2]
    L = params.L
    lam1, lam2 = lambdas(rho1, rho2, L)
    zero = np.zeros_like(rho1)
    xs = np.stack([zero, rho1, rho1 + rho2, rho1 + L * np.cos(beta), 0.5 * (rho1 + rho2), zero], -1)
    ys = np.stack([zero, zero, zero, L * np.sin(beta), 0.5 * lam1, lam2], -1)
    return np.stack([xs, ys], -1)


_I: Final = np.array([m.nodes[0] for m in MEMBERS])
_J: Final = np.array([m.nodes[1] for m in MEMBERS])


def member_vectors(q: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """Vectors from the first to the second node of each member, shape ``(..., 10, 2)``."""
    p = node_positions(q, params)
    return p[..., _J, :] - p[..., _I, :]


def member_lengths(q: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """Lengths L_1..L_10 of the members [m], shape ``(..., 10)`` (Eqs. 5-8, corrected Eq. 7).

    Computed from node differences, which stays accurate where the printed closed forms
    cancel (e.g. L_7 near the folded configuration).
    """
    lengths: NDArray[np.float64] = np.linalg.norm(member_vectors(q, params), axis=-1)
    return lengths


def alpha_of(rho1: ArrayLike, rho2: ArrayLike, L: float) -> NDArray[np.float64]:
    """Angle alpha of strut AE from +X [rad] (Eq. 1), in [0, pi/2]."""
    s = np.add(rho1, rho2)
    lam1, _ = lambdas(rho1, rho2, L)
    return np.arctan2(lam1, s)
