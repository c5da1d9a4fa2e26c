"""The paper's example structures as description files (package data).

``example_names()`` lists them, ``example_path(name)`` gives the file, ``load_example(name)``
the :class:`~tensegrity_core.general.structure.Structure`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.schema import ShippedFiles

_SHIPPED: Final = ShippedFiles(Path(__file__).parent, "example", "available", StructureError)


def example_names() -> list[str]:
    """Names of the shipped examples (file stems)."""
    return _SHIPPED.names()


def example_path(name: object) -> Path:
    """Path of the example ``name`` (e.g. ``"tensegrity_table"``)."""
    return _SHIPPED.path(name)


def load_example(name: str) -> Structure:
    """The example ``name`` as a structure."""
    from tensegrity_core.general.loading import structure_from_file

    return structure_from_file(example_path(name))
