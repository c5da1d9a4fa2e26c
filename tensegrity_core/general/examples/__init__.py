"""The paper's example structures as description files (package data).

``example_names()`` lists them, ``example_path(name)`` gives the file, ``load_example(name)``
the :class:`~tensegrity_core.general.structure.Structure`.
"""

from __future__ import annotations

from pathlib import Path

from tensegrity_core.general.structure import StructureError, suggest

_DIR = Path(__file__).parent


def example_names() -> list[str]:
    """Names of the shipped examples (file stems)."""
    return sorted(p.stem for p in _DIR.glob("*.yaml"))


def example_path(name: str) -> Path:
    """Path of the example ``name`` (e.g. ``"tensegrity_table"``)."""
    path = _DIR / f"{name}.yaml"
    if not path.is_file():
        raise StructureError(f"unknown example {name!r}{suggest(name, example_names())}; "
                             f"available: {', '.join(example_names())}")
    return path


def load_example(name: str):
    """The example ``name`` as a structure."""
    from tensegrity_core.general.loading import load_structure

    return load_structure(example_path(name))
