"""Errors of parameter sweeps.

:class:`SweepError` is raised while a sweep file is read and checked (it names the key path
into the sweep file and, for YAML, the line) and when a sweep cannot run at all (the
scheduler cannot be reached, the output belongs to another sweep, a dependency is missing).
A point that fails never raises: it becomes a row of the results with its status and message.
"""

from __future__ import annotations

from types import ModuleType

from tensegrity_core.errors import TensegrityError
from tensegrity_core.schema.errors import KeyPath, format_key_path


class SweepError(TensegrityError, ValueError):
    """A sweep is invalid or cannot run. ``key`` is the key path in the sweep file (tuple),
    ``line`` the 1-based line or ``None``, ``file`` the sweep file's name or ``None``; the
    message already contains all three."""

    def __init__(self, message: str, *, key: KeyPath = (), line: int | None = None, file: str | None = None):
        where = format_key_path(key)
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


class MissingDependencyError(SweepError):
    """Running a sweep needs packages the core does not (Dask distributed, pandas, pyarrow)."""


def require(module: str) -> ModuleType:
    """Import ``module`` for the sweep engine, or say what to install."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as err:
        raise MissingDependencyError(
            f"sweeps need the packages dask[distributed], pandas and pyarrow ({err}); "
            f"install them with: pip install 'tensegrity-ros[sweep]'") from None
