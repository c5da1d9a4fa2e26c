"""Which control rates a model's fixed step can take: the one check a scene's ``control``
and a :class:`~tensegrity_core.sim.control_loop.ControlLoop` share (a leaf module, so that
the scene schema need not import the loop, which imports the model, which reads scenes)."""

from __future__ import annotations

import math


def control_rate_reason(rate: float, step: float) -> str | None:
    """Why a controller cannot be sampled at ``rate`` [Hz] on a model taking fixed steps of
    ``step`` [s] (0: adaptive steps, any rate), or None when it can. Above ``1 / step`` it
    cannot: the motors take a new command at the start of a step, so samples between two
    steps see the same state and command nothing new (and each costs an evaluation: at 1 MHz
    a 10 ms run took 40 s)."""
    if not (rate > 0 and math.isfinite(rate)):
        return f"the control rate must be a positive number of Hz, got {rate!r}"
    if step > 0 and rate * step > 1.0 + 1e-12:
        return (f"a controller sampled at {rate:g} Hz is faster than the robot's fixed step of {step:g} s "
                f"({1.0 / step:g} Hz), at which its commands act; give rate in (0, {1.0 / step:g}] Hz")
    return None
