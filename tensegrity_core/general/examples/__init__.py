"""The paper's example structures as description files (package data).

``example_names()`` lists them, ``example_path(name)`` gives the file, ``load_example(name)``
the :class:`~tensegrity_core.general.structure.Structure`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.schema import excerpt, suggest

_DIR: Final = Path(__file__).parent


def example_names() -> list[str]:
    """Names of the shipped examples (file stems)."""
    return sorted(p.stem for p in _DIR.glob("*.yaml"))


def example_path(name: object) -> Path:
    """Path of the example ``name`` (e.g. ``"tensegrity_table"``)."""
    if not isinstance(name, str) or name not in example_names():
        raise StructureError(f"unknown example {excerpt(name)}{suggest(name, example_names())}; "
                             f"available: {', '.join(example_names())}")
    return _DIR / f"{name}.yaml"


def load_example(name: str) -> Structure:
    """The example ``name`` as a structure."""
    from tensegrity_core.general.loading import structure_from_file

    return structure_from_file(example_path(name))
