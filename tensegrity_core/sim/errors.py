"""Errors of the scene-driven simulator.

:class:`SceneError` is raised while a scene is read and checked: it names the key path
(e.g. ``effects[2].fold_limit.restitution``) and, when the scene came from YAML, the line.
:class:`SimulationError` is raised while a simulation runs (the state left the model's
domain, an integrator step failed, a command was not finite); the simulator keeps the last
good state.
"""

from __future__ import annotations

from tensegrity_core.errors import TensegrityError


def format_path(path: tuple) -> str:
    """``("effects", 2, "fold_limit")`` -> ``"effects[2].fold_limit"``."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


class SceneError(TensegrityError, ValueError):
    """A scene is invalid. ``key`` is the key path (tuple), ``line`` the 1-based YAML line
    or ``None``, ``file`` the scene file or ``None``. The message already contains all three."""

    def __init__(self, message: str, *, key: tuple = (), line: int | None = None, file: str | None = None):
        where = format_path(key)
        text = f"{where}: {message}" if where else message
        if line is not None:
            text += f" (line {line})"
        if file:
            text = f"{file}: {text}"
        super().__init__(text)
        self.key = tuple(key)
        self.line = line
        self.file = file
        self.reason = message


class SimulationError(TensegrityError, RuntimeError):
    """A running simulation cannot continue; ``t`` is the simulation time [s] of the failure."""

    def __init__(self, message: str, *, t: float = float("nan")):
        super().__init__(message)
        self.t = t
