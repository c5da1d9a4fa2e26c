"""Errors of the scene-driven simulator.

:class:`SceneError` is raised while a scene is read and checked: it names the key path
(e.g. ``effects[2].fold_limit.restitution``) and, when the scene came from YAML, the line.
:class:`SimulationError` is raised while a simulation runs (the state left the model's
domain, an integrator step failed, a command was not finite); the simulator keeps the last
good state.
"""

from __future__ import annotations

import math

from tensegrity_core.errors import TensegrityError
from tensegrity_core.schema import SchemaError


class SceneError(SchemaError):
    """A scene is invalid. ``key`` is the key path (tuple), ``line`` the 1-based YAML line
    or ``None``, ``file`` the scene file or ``None``; ``str()`` shows all three
    (``scene.yaml: effects[2].fold_limit: ... (line 14)``), ``reason`` the bare message."""


class SimulationError(TensegrityError, RuntimeError):
    """A running simulation cannot continue; ``t`` is the simulation time [s] of the failure."""

    def __init__(self, message: str, *, t: float = float("nan")):
        super().__init__(message)
        self.t = t


def check_advance_target(t: float, t_target: float) -> None:
    """Raise :class:`SimulationError` unless ``t_target`` [s] is where a state at ``t`` [s]
    may advance to: a finite time, not before ``t``."""
    if not math.isfinite(t_target):
        raise SimulationError(f"advance: the target time must be a finite number of seconds, got {t_target!r}", t=t)
    if t_target < t:
        raise SimulationError(f"cannot advance backwards: t = {t!r} s, target {t_target!r} s", t=t)
