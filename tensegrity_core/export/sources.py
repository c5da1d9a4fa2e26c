"""What an exporter reads: a shipped scene or example by name, or a scene or structure file."""

from __future__ import annotations

from pathlib import Path

from tensegrity_core.export.errors import ExportError
from tensegrity_core.general.examples import example_names, load_example
from tensegrity_core.general.loading import SUFFIXES, structure_from_file
from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.schema import excerpt, read_file, suggest
from tensegrity_core.sim.scene import Scene, scene_from_file, scene_names, scene_path


def load_source(source: str) -> Scene | Structure:
    """The scene or structure ``source`` names: an existing file (a scene file is a YAML
    mapping with a ``model`` key; anything else of the structure formats
    ``.yaml``/``.yml``/``.json``/``.toml``/``.npz`` is read as a structure), else a shipped
    scene's name, else a shipped example's name. Raises a ``SceneError`` or
    ``StructureError`` located in the file, or :class:`ExportError`."""
    path = Path(source)
    if _is_file(path):
        return _load_file(path)
    if source in scene_names():
        return scene_from_file(scene_path(source))
    if source in example_names():
        return load_example(source)
    names = scene_names() + example_names()
    raise ExportError(f"no scene or structure file {excerpt(source)}, and no shipped scene or example of that name"
                      f"{suggest(source, names)}; shipped scenes: {', '.join(scene_names())}; shipped examples: "
                      f"{', '.join(example_names())}")


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except OSError:                       # e.g. a name longer than the system allows
        return False


def _load_file(path: Path) -> Scene | Structure:
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ExportError(f"cannot tell what {excerpt(str(path))} is: a scene file ends in .yaml or .yml, a "
                          f"structure file in {', '.join(SUFFIXES)}")
    if suffix not in (".yaml", ".yml"):
        return structure_from_file(path)
    data, _, _ = read_file(path, error=StructureError, what="file")
    if isinstance(data, dict) and "model" in data:
        return scene_from_file(path)
    try:
        return structure_from_file(path)
    except StructureError as err:
        raise ExportError(f"{err} (read as a structure: it has no 'model' key, so it is no scene)") from None
