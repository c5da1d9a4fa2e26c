"""Cable motors: the rest length of an actuated cable as the motor's state.

A motor reels its cable in and out; the cable element (:mod:`.cable`) sees the result as
its rest length ``l0`` [m]. Parameters per motor: the rest-length range ``[lo, hi]`` [m],
a first-order lag ``tau`` [s] (0: none), a slew-rate limit ``speed`` [m/s] (inf: none)
and the tension limit ``t_max`` [N].

**Modes** (per motor; what its command ``u`` means):

- ``rest_length``: ``u`` [m] is the target rest length, clipped to the range
  (:func:`target`), reached through the dynamics below;
- ``tension``: ``u`` [N] is a target tension, clipped to ``[0, t_max]``: the motor aims at
  the rest length that gives that tension at the cable's present length ``l``,
  ``clip(l - u / k, lo, hi)`` (:func:`target`), through the same dynamics. At rest
  (``ldot = 0``, ``l0`` = its aim inside the range) the cable's tension
  ``k (l - l0) = u``: a fast motor makes the cable a constant-tension source; at a range
  end the motor can do no more (the tension is what the range allows);
- ``reel_speed``: ``u`` [m/s] is the reel speed (positive pays out, lengthening the rest
  length), clipped to ``[-speed, speed]``; the rest length moves at that speed until an
  end of the range (:func:`reel`): ``l0(t + dt) = clip(l0 + clip(u, -speed, speed) dt,
  lo, hi)``. The lag does not apply (the command is the spool's speed itself).

**Dynamics** (:func:`rate`; exact over a step by :func:`step`)::

    dl0/dt = clip((target - l0) / tau, -speed, speed)

a lag whose rate is limited: far from the target the motor slews at ``speed``, within
``speed tau`` of it the error decays as ``exp(-t / tau)``. ``tau = 0`` is a pure slew
limit, ``speed = inf`` a pure lag; with neither the motor is ideal (``l0 = target`` at
once), which only :func:`step` represents (a model without a motor state).

**Tension limit** (:func:`payout`). A motor cannot hold more than ``t_max``: when the cable
pulls harder the spool is back-driven and pays out, keeping ``k (l - l0) <= t_max`` (up to
the range's end, ``hi``, where the motor is at its stop). Paying out lowers the stored
energy ``k (l - l0)^2 / 2``: the motor's brake dissipates it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

#: Command modes: the command is a rest length [m], a reel speed [m/s] or a tension [N].
REST_LENGTH, REEL_SPEED, TENSION = 0, 1, 2
MODES = {"rest_length": REST_LENGTH, "reel_speed": REEL_SPEED, "tension": TENSION}
#: The unit of a mode's command.
UNITS = {REST_LENGTH: "m", REEL_SPEED: "m/s", TENSION: "N"}


def target(mode: ArrayLike, command: ArrayLike, l: ArrayLike, k: ArrayLike, lo: ArrayLike,
           hi: ArrayLike, t_max: ArrayLike = np.inf) -> FloatArray:
    """The rest length [m] each rest-length or tension motor aims at: ``clip(u, lo, hi)`` in
    rest-length mode, ``clip(l - clip(u, 0, t_max) / k, lo, hi)`` in tension mode (``u``
    [N], cable length ``l`` [m], stiffness ``k`` [N/m], tension limit ``t_max`` [N])."""
    u = np.asarray(command, dtype=float)
    pull = np.clip(u, 0.0, t_max) / np.asarray(k, dtype=float)
    aim = np.where(np.asarray(mode) == TENSION, np.asarray(l, dtype=float) - pull, u)
    out: FloatArray = np.clip(aim, lo, hi)
    return out


def reel(l0: ArrayLike, command: ArrayLike, speed: ArrayLike, lo: ArrayLike, hi: ArrayLike,
         dt: float) -> FloatArray:
    """The rest lengths [m] of reel-speed motors after ``dt`` [s] at the commanded speed
    ``u`` [m/s] within the slew limit ``speed``: ``clip(l0 + clip(u, -speed, speed) dt, lo, hi)``."""
    s = np.asarray(speed, dtype=float)
    v = np.clip(np.asarray(command, dtype=float), -s, s)
    out: FloatArray = np.clip(np.asarray(l0, dtype=float) + v * dt, lo, hi)
    return out


def rate(l0: ArrayLike, aim: ArrayLike, tau: ArrayLike, speed: ArrayLike) -> FloatArray:
    """``dl0/dt`` [m/s] = ``clip((aim - l0) / tau, -speed, speed)``; ``tau = 0`` slews at
    ``speed`` towards ``aim`` (0 at it). Needs ``tau > 0`` or a finite ``speed``."""
    e = np.asarray(aim, dtype=float) - np.asarray(l0, dtype=float)
    t = np.asarray(tau, dtype=float)
    s = np.asarray(speed, dtype=float)
    unlagged = np.where(e > 0, np.inf, np.where(e < 0, -np.inf, 0.0))    # tau = 0: as fast as the slew
    lagged = np.divide(e, t, out=unlagged, where=t > 0)
    out: FloatArray = np.clip(lagged, -s, s)
    return out


def step(l0: ArrayLike, aim: ArrayLike, tau: ArrayLike, speed: ArrayLike, dt: float) -> FloatArray:
    """The rest lengths [m] after ``dt`` [s] of :func:`rate` towards a constant ``aim``,
    exactly: a slew at ``speed`` until the error is ``speed tau``, then the exponential
    ``e exp(-t / tau)``. Ideal motors (``tau = 0``, ``speed = inf``) reach ``aim``."""
    A = np.asarray(aim, dtype=float)
    e0 = A - np.asarray(l0, dtype=float)
    t = np.asarray(tau, dtype=float)
    s = np.asarray(speed, dtype=float)
    mag = np.abs(e0)
    knee = np.multiply(s, t, out=np.zeros_like(mag), where=t > 0)    # |error| where the slew ends
    slew_time = np.divide(mag - knee, s, out=np.zeros_like(mag), where=(mag > knee) & np.isfinite(s))
    slewing = dt < slew_time
    travel = np.multiply(s, dt, out=np.full_like(mag, np.inf), where=np.isfinite(s))
    after_slew = np.maximum(mag - travel, 0.0)
    start = np.minimum(mag, knee)
    decay = np.exp(-np.divide(np.maximum(dt - slew_time, 0.0), t, out=np.full_like(mag, np.inf), where=t > 0))
    left = np.where(slewing, after_slew, start * decay)
    out: FloatArray = A - np.sign(e0) * left
    return out


def payout(l0: ArrayLike, l: ArrayLike, k: ArrayLike, t_max: ArrayLike, hi: ArrayLike) -> FloatArray:
    """Rest lengths [m] after the spools pay out under the tension limit: ``l0`` raised to
    ``l - t_max / k`` where the cable (length ``l``) would pull harder, at most to ``hi``."""
    L0 = np.asarray(l0, dtype=float)
    need = np.asarray(l, dtype=float) - np.asarray(t_max, dtype=float) / np.asarray(k, dtype=float)
    out: FloatArray = np.maximum(L0, np.minimum(need, hi))
    return out


def settling_time(gap: ArrayLike, tolerance: float, tau: ArrayLike, speed: ArrayLike) -> FloatArray:
    """s a rest-length motor needs to bring an error of ``gap`` [m] (towards a constant aim)
    within ``tolerance`` [m] under :func:`rate`: the slew at ``speed`` [m/s] down to
    ``speed tau`` (or to ``tolerance``, if that is larger), then the decay ``exp(-t / tau)``
    to ``tolerance``. 0 where ``gap <= tolerance``; ``tau = 0`` and ``speed = inf``: 0
    (ideal). Needs ``tolerance > 0``."""
    g = np.abs(np.asarray(gap, dtype=float))
    t = np.asarray(tau, dtype=float)
    s = np.asarray(speed, dtype=float)
    knee = np.maximum(np.multiply(s, t, out=np.full_like(g, np.inf), where=np.isfinite(s)), tolerance)
    slew_end = np.minimum(g, knee)
    slew = np.divide(g - slew_end, s, out=np.zeros_like(g), where=np.isfinite(s))
    decay = t * np.log(np.maximum(slew_end, tolerance) / tolerance)
    out: FloatArray = slew + decay
    return out
