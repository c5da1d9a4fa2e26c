"""Where a scene refers to other files, and how those references are resolved.

A scene names other files in these places, all relative to the scene file's folder (the
current folder for text and dicts):

- ``model.structure`` of a general scene: a structure file or a shipped example's name
  (or the description inline, a mapping): :func:`structure_source`;
- ``model.robot`` of a robot scene: a robot file or a shipped robot's name (or the
  description inline): :func:`robot_source`;
- the ``file`` of a ``law: series`` input: a CSV table: :func:`series_file`;
- the ``file`` of ``inputs.gait`` (a robot's gait): a gait file or a shipped gait's name
  (:func:`~tensegrity_core.robot.gait.gait_file`, which the gait reader uses too).

The scene reader resolves them with these functions, and :func:`self_contained` uses the
same ones to make a parsed scene document that needs no other file: the structure or robot
inlined as its parsed description (so key paths such as
``model.structure.members[side*].EA`` reach it) and CSV and gait files as absolute paths. A sweep sends such a document to its workers
(the workers of an external cluster must then see the same file system for CSV files).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tensegrity_core.general.examples import SHIPPED_EXAMPLES
from tensegrity_core.general.loading import SUFFIXES as STRUCTURE_SUFFIXES
from tensegrity_core.general.structure import StructureError
from tensegrity_core.robot.gait import gait_file
from tensegrity_core.schema import SchemaError, Source, plain, read_file, resolve_source
from tensegrity_core.sim.errors import SceneError


def structure_source(value: object, folder: Path) -> Source:
    """What ``model.structure`` names: a mapping (the description), a structure file relative
    to ``folder`` or a shipped example's name; :class:`SceneError` (bare reason) if none."""
    return resolve_source(value, what="structure", shipped=SHIPPED_EXAMPLES, error=SceneError,
                          suffixes=STRUCTURE_SUFFIXES, folder=folder, text=None)


def robot_source(value: object, folder: Path) -> Source:
    """What ``model.robot`` names: a mapping (the description), a robot file relative to
    ``folder`` or a shipped robot's name; :class:`SceneError` (bare reason) if none."""
    from tensegrity_core.robot.loading import SHIPPED_ROBOTS, SUFFIXES

    return resolve_source(value, what="robot", shipped=SHIPPED_ROBOTS, error=SceneError, suffixes=SUFFIXES,
                          folder=folder, text=None)


def series_file(value: str, folder: Path) -> Path:
    """The CSV file a series law's ``file`` names (relative to ``folder``)."""
    return folder / value


def self_contained(document: dict[str, Any], folder: Path) -> dict[str, Any]:
    """A copy of the parsed scene ``document`` (plain dicts and lists) that refers to no
    other file (see the module's docstring); files relative to ``folder``. A reference that
    cannot be read raises the error its reader raises (``SceneError``, ``StructureError``)."""
    out: dict[str, Any] = plain(document)
    model = out.get("model")
    if isinstance(model, dict) and model.get("kind") == "general" and isinstance(model.get("structure"), str):
        model["structure"] = _inlined(structure_source(model["structure"], folder), StructureError, "structure")
    if isinstance(model, dict) and model.get("kind") == "robot" and isinstance(model.get("robot"), str):
        from tensegrity_core.robot.description import RobotError

        model["robot"] = _inlined(robot_source(model["robot"], folder), RobotError, "robot")
    inputs = out.get("inputs")
    if isinstance(inputs, dict):
        gait = inputs.get("gait")
        if isinstance(gait, dict) and isinstance(gait.get("file"), str):
            gait["file"] = str(gait_file(gait["file"], folder, SceneError).resolve())
        for law in inputs.values():
            if isinstance(law, dict) and law.get("law") == "series" and isinstance(law.get("file"), str):
                law["file"] = str(series_file(law["file"], folder).resolve())
    return out


def _inlined(source: Source, error: type[SchemaError], what: str) -> dict[str, Any]:
    """The parsed description in the file ``source`` names, with its name (default: the
    file's stem)."""
    assert source.path is not None                     # text and data are not accepted
    data = plain(read_file(source.path, error=error, what=f"{what} file")[0])
    if not isinstance(data, dict):
        raise error(f"a {what} description must be a mapping", file=source.path.name)
    data.setdefault("name", source.path.stem)
    return data
