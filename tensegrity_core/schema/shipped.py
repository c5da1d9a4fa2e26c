"""Description files shipped as package data (example structures, scenes, sweeps), by name.

A folder of ``NAME.yaml`` files is a :class:`ShippedFiles`: :meth:`~ShippedFiles.names`
lists the names (file stems, sorted), :meth:`~ShippedFiles.path` gives one file or raises the
format's error naming the closest name and listing them all, e.g.
``unknown scene 'paper_fodl' (did you mean 'paper_fold'?); shipped scenes: ...``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from tensegrity_core.schema.errors import excerpt, suggest


@dataclass(frozen=True)
class ShippedFiles:
    """The ``*.yaml`` files of ``folder``. Messages call one of them ``what`` (``"scene"``)
    and introduce the list of names with ``listing`` (``"shipped scenes"``); ``error`` makes
    the exception raised for an unknown name from its message."""

    folder: Path
    what: str
    listing: str
    error: Callable[[str], Exception]

    def names(self) -> list[str]:
        """The names of the files (their stems), sorted."""
        return sorted(p.stem for p in self.folder.glob("*.yaml"))

    def path(self, name: object) -> Path:
        """The file called ``name``; ``error`` if there is none."""
        names = self.names()
        if not isinstance(name, str) or name not in names:
            raise self.error(f"unknown {self.what} {excerpt(name)}{suggest(name, names)}; "
                             f"{self.listing}: {', '.join(names)}")
        return self.folder / f"{name}.yaml"
