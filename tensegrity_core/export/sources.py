"""What an exporter reads: a shipped scene, robot or example by name, or a scene, robot or structure file."""

from __future__ import annotations

from pathlib import Path

from tensegrity_core.export.errors import ExportError
from tensegrity_core.general.examples import SHIPPED_EXAMPLES
from tensegrity_core.general.loading import SUFFIXES, structure_from_file
from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.loading import SHIPPED_ROBOTS, robot_from_file
from tensegrity_core.schema import excerpt, read_file, resolve_source
from tensegrity_core.sim.scene import Scene, scene_from_file
from tensegrity_core.sim.scene.reader import SHIPPED_SCENES


def load_source(source: str) -> Scene | Structure | Robot:
    """The scene, robot or structure ``source`` names: an existing file (a scene file is a
    YAML mapping with a ``model`` key, a robot file one with ``cables``; anything else of the
    structure formats ``.yaml``/``.yml``/``.json``/``.toml``/``.npz`` is read as a structure),
    else a shipped scene's name, else a shipped robot's, else a shipped example's (the rules
    of :func:`~tensegrity_core.schema.resolve_source`). Raises a ``SceneError``,
    ``RobotError`` or ``StructureError`` located in the file, or :class:`ExportError`."""
    found = resolve_source(source, what="scene, robot or structure",
                           shipped=(SHIPPED_SCENES, SHIPPED_ROBOTS, SHIPPED_EXAMPLES), error=ExportError,
                           suffixes=SUFFIXES, text=None, data=False)
    assert found.path is not None                  # text and data are refused above
    if found.shipped is SHIPPED_SCENES:
        return scene_from_file(found.path)
    if found.shipped is SHIPPED_ROBOTS:
        return robot_from_file(found.path)
    if found.shipped is SHIPPED_EXAMPLES:
        return structure_from_file(found.path)
    return _load_file(found.path)


def _load_file(path: Path) -> Scene | Structure | Robot:
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ExportError(f"cannot tell what {excerpt(str(path))} is: a scene file ends in .yaml or .yml, a "
                          f"structure file in {', '.join(SUFFIXES)}")
    if suffix == ".npz":
        return structure_from_file(path)
    data, _, _ = read_file(path, error=StructureError, what="file")
    if isinstance(data, dict) and "model" in data and suffix in (".yaml", ".yml"):
        return scene_from_file(path)
    if isinstance(data, dict) and "cables" in data:
        return robot_from_file(path)
    try:
        return structure_from_file(path)
    except StructureError as err:
        raise ExportError(f"{err} (read as a structure: it has no 'model' key, so it is no scene, and no "
                          f"'cables' key, so it is no robot)") from None
