"""Reading scenes: from YAML text, a file, parsed data or a shipped scene's name, checked before anything runs.

Entry points, one per kind of source: :func:`scene_from_text` (YAML text; never opens the
file a one-line text might name, except the structure, robot, gait and CSV files the scene
lists, relative to ``base``), :func:`scene_from_file` (a ``.yaml``/``.yml`` file),
:func:`scene_from_dict` (parsed data), a shipped scene by :func:`scene_path`; and
:func:`load_scene`, the convenience for local use that accepts a shipped scene's name, a
path, YAML text or a dict. Each returns a frozen :class:`~tensegrity_core.sim.scene.spec.Scene`
checked by the scene's schema (:class:`~tensegrity_core.sim.scene.schema.SceneReader`), or
raises :class:`~tensegrity_core.sim.errors.SceneError` with the key path and the line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Final, cast

from tensegrity_core.schema import DEFAULT_LIMITS, Limits, ShippedFiles, parse_text, read_file, resolve_source
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.scene.schema import SceneReader
from tensegrity_core.sim.scene.spec import Scene

#: The shipped scenes' folder.
SCENES_DIR = Path(__file__).parents[1] / "scenes"
#: The shipped scenes, by name.
SHIPPED_SCENES: Final = ShippedFiles(SCENES_DIR, "scene", "shipped scenes", SceneError)


def scene_names() -> list[str]:
    """Names of the shipped scenes (file stems in the package's ``scenes`` folder)."""
    return SHIPPED_SCENES.names()


def scene_path(name: str) -> Path:
    """Path of the shipped scene ``name``."""
    return SHIPPED_SCENES.path(name)


def scene_from_text(text: str, *, base: str | Path | None = None, limits: Limits = DEFAULT_LIMITS) -> Scene:
    """The scene in YAML ``text``; files it lists are relative to ``base`` (default: the
    current folder)."""
    data = parse_text(text, "yaml", limits=limits, error=SceneError)
    return SceneReader(None, Path(base) if base is not None else Path.cwd()).scene(data)


def scene_from_file(path: str | Path, *, limits: Limits = DEFAULT_LIMITS) -> Scene:
    """The scene in the file ``path`` (``.yaml``/``.yml``); files it lists are relative to
    its folder, errors name it."""
    path = Path(path)
    data, _, _ = read_file(path, limits=limits, error=SceneError, fmt="yaml", what="scene file")
    return SceneReader(path.name, path.parent.resolve(), str(path)).scene(data)


def scene_from_dict(data: dict[str, Any], *, base: str | Path | None = None) -> Scene:
    """The scene in parsed data ``data``; files it lists are relative to ``base``."""
    return SceneReader(None, Path(base) if base is not None else Path.cwd()).scene(data)


#: What :func:`load_scene` reads: a scene, a shipped scene's name, a path, YAML text or a dict.
SceneSource = Scene | str | Path | dict[str, Any]


def load_scene(source: SceneSource) -> Scene:
    """Read and check a scene: a :class:`Scene` (returned as is), a path (``str`` or
    ``Path``) to an existing file or a shipped scene's name, YAML text, or a dict (the rules
    of :func:`~tensegrity_core.schema.resolve_source`). For local use (a Python session,
    the CLI): text from elsewhere goes to :func:`scene_from_text`.

    Relative paths inside the scene (structure files, CSV series) are resolved against the
    scene file's folder (the current folder for text and dicts)."""
    if isinstance(source, Scene):
        return source
    found = resolve_source(source, what="scene", shipped=SHIPPED_SCENES, error=SceneError)
    if found.kind == "data":
        return scene_from_dict(cast(dict[str, Any], found.data))
    if found.kind == "text":
        return scene_from_text(cast(str, found.text))
    return scene_from_file(cast(Path, found.path))
