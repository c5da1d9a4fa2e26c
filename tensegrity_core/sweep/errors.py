"""Errors of parameter sweeps.

:class:`SweepError` is raised while a sweep file is read and checked (it names the key path
into the sweep file and, for YAML, the line) and when a sweep cannot run at all (the
scheduler cannot be reached, the output belongs to another sweep, a dependency is missing).
A point that fails never raises: it becomes a row of the results with its status and message.
"""

from __future__ import annotations

from types import ModuleType

from tensegrity_core.schema.errors import SchemaError


class SweepError(SchemaError):
    """A sweep is invalid or cannot run. ``key`` is the key path in the sweep file (tuple),
    ``line`` the 1-based line or ``None``, ``file`` the sweep file's name or ``None``;
    ``str()`` shows all three (:class:`~tensegrity_core.schema.SchemaError`), ``reason``
    the bare message."""


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
            f"install them with: pip install '.[sweep]' in the project's folder (./run setup does)") from None
