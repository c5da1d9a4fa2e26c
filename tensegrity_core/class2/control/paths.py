"""End-effector paths in time: where node D should be, rest to rest.

A path gives ``D(t)``, ``D'(t)``, ``D''(t)`` [m, m/s, m/s^2] for ``0 <= t <= duration``
(held constant outside), its points ``point(sigma)`` for the path parameter ``sigma`` in
[0, 1] and ``sigma(t)``. Every path here moves along its curve with the rest-to-rest
time scaling :func:`smooth_step`, whose first four derivatives vanish at both ends: the
reference built on it (:mod:`~tensegrity_core.class2.control.flat`) depends on D up to its
fourth derivative, so it starts and ends at rest with continuous forces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final, Protocol, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Peak of ``smooth_step'``: the path's peak speed is this times its mean speed.
PEAK_SPEED_FACTOR: Final = 630.0 / 256.0

#: Three arrays of one shape: a value and its first two derivatives.
Derivatives: TypeAlias = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


class EndEffectorPath(Protocol):
    """What a planner reads of a path of node D (:class:`LinePath`, :class:`CirclePath`)."""

    @property
    def duration(self) -> float:
        """Time from start to end [s]."""
        ...

    def point(self, sigma: ArrayLike) -> NDArray[np.float64]:
        """Points (x, y) [m] at the path parameters ``sigma`` in [0, 1], shape (N, 2)."""
        ...

    def sample(self, t: ArrayLike) -> Derivatives:
        """``(D, D', D'')`` at the times ``t`` [s], each (N, 2)."""
        ...


class MeasuredPath(EndEffectorPath, Protocol):
    """A path with its length and its parameter in time, for IK samples along it."""

    @property
    def length(self) -> float:
        """Length of the curve [m]."""
        ...

    def sigma(self, t: ArrayLike) -> NDArray[np.float64]:
        """The path parameters in [0, 1] at the times ``t`` [s]."""
        ...


def smooth_step(u: ArrayLike) -> Derivatives:
    """``(s, s', s'')`` of the 9th-order rest-to-rest polynomial on ``u`` in [0, 1]
    (clipped): ``s' = 630 u^4 (1 - u)^4``, ``s(0) = 0``, ``s(1) = 1``, derivatives 1..4 zero
    at both ends."""
    u = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
    v = 1.0 - u
    s = u**5 * (126.0 + u * (-420.0 + u * (540.0 + u * (-315.0 + 70.0 * u))))
    return s, 630.0 * (u * v) ** 4, 2520.0 * (u * v) ** 3 * (1.0 - 2.0 * u)


@dataclass(frozen=True)
class LinePath:
    """A straight line from ``start`` to ``end`` (x, y) [m] in ``duration`` [s]."""

    start: tuple[float, float]
    end: tuple[float, float]
    duration: float

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    def sigma(self, t: ArrayLike) -> NDArray[np.float64]:
        return smooth_step(np.asarray(t, dtype=float) / self.duration)[0]

    def point(self, sigma: ArrayLike) -> NDArray[np.float64]:
        """Points at the path parameters ``sigma`` in [0, 1], shape (N, 2)."""
        p0, p1 = np.asarray(self.start, dtype=np.float64), np.asarray(self.end, dtype=np.float64)
        points: NDArray[np.float64] = p0 + np.asarray(sigma, dtype=np.float64)[:, None] * (p1 - p0)
        return points

    def sample(self, t: ArrayLike) -> Derivatives:
        """``(D, D', D'')`` at the times ``t`` [s], each (N, 2)."""
        T = self.duration
        s, sd, sdd = smooth_step(np.asarray(t, dtype=float) / T)
        delta = np.asarray(self.end, dtype=float) - np.asarray(self.start, dtype=float)
        return self.point(s), (sd / T)[:, None] * delta, (sdd / T**2)[:, None] * delta


def smooth_step_integral(u: ArrayLike) -> NDArray[np.float64]:
    """``S(u) = int_0^u s``: ``21 u^6 - 60 u^7 + 67.5 u^8 - 35 u^9 + 7 u^10`` on [0, 1]
    (clipped at 0; ``S(1) = 1/2``, and ``S(u) = u - 1/2`` beyond 1)."""
    uc: NDArray[np.float64] = np.maximum(np.asarray(u, dtype=np.float64), 0.0)
    v = np.minimum(uc, 1.0)
    return v**6 * (21.0 + v * (-60.0 + v * (67.5 + v * (-35.0 + 7.0 * v)))) + (uc - v)


@dataclass(frozen=True)
class CirclePath:
    """``turns`` turns counter-clockwise round ``center`` (x, y) [m] at ``radius`` [m], one
    turn per ``period`` [s], starting at the angle ``phase`` [rad] from +X.

    The angular rate ``w = 2 pi / period`` is reached from rest in ``ramp`` seconds (rate
    ``w s(t/ramp)``) and left again in ``ramp`` seconds at the end, so the path is at rest
    at both ends; between ``ramp`` and ``ramp + turns * period`` it turns at constant rate
    (:attr:`steady`). ``duration = 2 ramp + turns period``.
    """

    center: tuple[float, float]
    radius: float
    period: float
    phase: float = 0.0
    turns: float = 1.0
    ramp: float = 2.0

    @property
    def duration(self) -> float:
        return 2.0 * self.ramp + self.turns * self.period

    @property
    def steady(self) -> tuple[float, float]:
        """The time interval [s] of the constant-rate turns."""
        return self.ramp, self.ramp + self.turns * self.period

    @property
    def angle(self) -> float:
        """Total angle turned [rad]."""
        return 2.0 * math.pi / self.period * (self.ramp + self.turns * self.period)

    @property
    def length(self) -> float:
        return self.radius * self.angle

    def _phi(self, t: ArrayLike) -> Derivatives:
        """Angle swept, its rate and acceleration at the times ``t``."""
        tc: NDArray[np.float64] = np.clip(np.asarray(t, dtype=np.float64), 0.0, self.duration)
        w, R, T = 2.0 * math.pi / self.period, self.ramp, self.duration
        up, down = tc / R, (T - tc) / R
        s_up, sd_up, _ = smooth_step(up)
        s_dn, sd_dn, _ = smooth_step(down)
        rate = w * np.minimum(s_up, s_dn)
        acc = np.where(tc <= 0.5 * T, w * sd_up / R, -w * sd_dn / R)
        angle = np.where(tc <= 0.5 * T, w * R * smooth_step_integral(up),
                         self.angle - w * R * smooth_step_integral(down))
        return angle, rate, acc

    def sigma(self, t: ArrayLike) -> NDArray[np.float64]:
        return self._phi(t)[0] / self.angle

    def point(self, sigma: ArrayLike) -> NDArray[np.float64]:
        phi = self.phase + self.angle * np.asarray(sigma, dtype=float)
        c = np.asarray(self.center, dtype=float)
        return c + self.radius * np.stack([np.cos(phi), np.sin(phi)], -1)

    def sample(self, t: ArrayLike) -> Derivatives:
        angle, phid, phidd = self._phi(t)
        r = self.radius
        phi = self.phase + angle
        cos, sin = np.cos(phi), np.sin(phi)
        D = np.asarray(self.center, dtype=float) + r * np.stack([cos, sin], -1)
        Dd = r * np.stack([-sin * phid, cos * phid], -1)
        Ddd = r * np.stack([-cos * phid**2 - sin * phidd, -sin * phid**2 + cos * phidd], -1)
        return D, Dd, Ddd
