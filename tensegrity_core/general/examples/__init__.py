"""The paper's example structures as description files (package data).

``example_names()`` lists them, ``example_path(name)`` gives the file;
:func:`~tensegrity_core.general.loading.load_example` reads one into a
:class:`~tensegrity_core.general.structure.Structure`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

from tensegrity_core.general.structure import StructureError
from tensegrity_core.schema import ShippedFiles

#: The shipped examples, by name.
SHIPPED_EXAMPLES: Final = ShippedFiles(Path(__file__).parent, "example", "shipped examples", StructureError)


def example_names() -> list[str]:
    """Names of the shipped examples (file stems)."""
    return SHIPPED_EXAMPLES.names()


def example_path(name: object) -> Path:
    """Path of the example ``name`` (e.g. ``"tensegrity_table"``)."""
    return SHIPPED_EXAMPLES.path(name)

