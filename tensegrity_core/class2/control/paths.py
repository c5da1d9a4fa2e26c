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

import numpy as np

#: Peak of ``smooth_step'``: the path's peak speed is this times its mean speed.
PEAK_SPEED_FACTOR = 630.0 / 256.0


def smooth_step(u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(s, s', s'')`` of the 9th-order rest-to-rest polynomial on ``u`` in [0, 1]
    (clipped): ``s' = 630 u^4 (1 - u)^4``, ``s(0) = 0``, ``s(1) = 1``, derivatives 1..4 zero
    at both ends."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
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

    def sigma(self, t) -> np.ndarray:
        return smooth_step(np.asarray(t, dtype=float) / self.duration)[0]

    def point(self, sigma) -> np.ndarray:
        """Points at the path parameters ``sigma`` in [0, 1], shape (N, 2)."""
        p0, p1 = np.asarray(self.start, dtype=float), np.asarray(self.end, dtype=float)
        return p0 + np.asarray(sigma, dtype=float)[:, None] * (p1 - p0)

    def sample(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(D, D', D'')`` at the times ``t`` [s], each (N, 2)."""
        T = self.duration
        s, sd, sdd = smooth_step(np.asarray(t, dtype=float) / T)
        delta = np.asarray(self.end, dtype=float) - np.asarray(self.start, dtype=float)
        return self.point(s), (sd / T)[:, None] * delta, (sdd / T**2)[:, None] * delta


def smooth_step_integral(u) -> np.ndarray:
    """``S(u) = int_0^u s``: ``21 u^6 - 60 u^7 + 67.5 u^8 - 35 u^9 + 7 u^10`` on [0, 1]
    (clipped at 0; ``S(1) = 1/2``, and ``S(u) = u - 1/2`` beyond 1)."""
    u = np.maximum(np.asarray(u, dtype=float), 0.0)
    v = np.minimum(u, 1.0)
    return v**6 * (21.0 + v * (-60.0 + v * (67.5 + v * (-35.0 + 7.0 * v)))) + (u - v)


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

    def _phi(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angle swept, its rate and acceleration at the times ``t``."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        w, R, T = 2.0 * math.pi / self.period, self.ramp, self.duration
        up, down = t / R, (T - t) / R
        s_up, sd_up, _ = smooth_step(up)
        s_dn, sd_dn, _ = smooth_step(down)
        rate = w * np.minimum(s_up, s_dn)
        acc = np.where(t <= 0.5 * T, w * sd_up / R, -w * sd_dn / R)
        angle = np.where(t <= 0.5 * T, w * R * smooth_step_integral(up),
                         self.angle - w * R * smooth_step_integral(down))
        return angle, rate, acc

    def sigma(self, t) -> np.ndarray:
        return self._phi(t)[0] / self.angle

    def point(self, sigma) -> np.ndarray:
        phi = self.phase + self.angle * np.asarray(sigma, dtype=float)
        c = np.asarray(self.center, dtype=float)
        return c + self.radius * np.stack([np.cos(phi), np.sin(phi)], -1)

    def sample(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        angle, phid, phidd = self._phi(t)
        r = self.radius
        phi = self.phase + angle
        cos, sin = np.cos(phi), np.sin(phi)
        D = np.asarray(self.center, dtype=float) + r * np.stack([cos, sin], -1)
        Dd = r * np.stack([-sin * phid, cos * phid], -1)
        Ddd = r * np.stack([-cos * phid**2 - sin * phidd, -sin * phid**2 + cos * phidd], -1)
        return D, Dd, Ddd
