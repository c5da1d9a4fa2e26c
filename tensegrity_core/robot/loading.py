"""Robot descriptions from text, files, parsed data and the shipped robots: the entry points.

- :func:`robot_from_text`: description text (YAML, JSON or TOML); never opens a file.
- :func:`robot_from_file`: a ``.yaml``/``.yml``, ``.json`` or ``.toml`` file.
- :func:`~tensegrity_core.robot.robot_schema.robot_from_dict`: parsed data.
- :func:`robot_names`, :func:`robot_path`: the shipped robots (``three_bar``, ``six_bar``,
  ``spine``).
- :func:`load_robot`: the convenience for local use: a :class:`Robot`, a shipped robot's
  name, a path or a dict.

Text is bounded by :class:`~tensegrity_core.schema.Limits` as every description is; errors
are :class:`RobotError` with the key path, the line (YAML) and the file's name.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Final

from tensegrity_core.robot.description import Robot, RobotError
from tensegrity_core.robot.robot_schema import robot_from_dict
from tensegrity_core.schema import (
    DEFAULT_LIMITS,
    Limits,
    ShippedFiles,
    excerpt,
    parse_text_format,
    read_file,
    resolve_source,
)

EXAMPLES: Final = Path(__file__).parent / "examples"
#: The shipped robots, by name.
SHIPPED_ROBOTS: Final = ShippedFiles(EXAMPLES, "robot", "shipped robots", RobotError)
SUFFIXES: Final = (".yaml", ".yml", ".json", ".toml")


def robot_names() -> list[str]:
    """Names of the shipped robots."""
    return SHIPPED_ROBOTS.names()


def robot_path(name: object) -> Path:
    """The file of the shipped robot ``name``."""
    return SHIPPED_ROBOTS.path(name)


def robot_from_text(text: str, fmt: str | None = None, *, limits: Limits = DEFAULT_LIMITS,
                    name: str = "robot") -> Robot:
    """The robot described by ``text`` (``fmt``: ``"yaml"``, ``"json"``, ``"toml"`` or None to
    guess); ``name`` when the text gives none."""
    data, _ = parse_text_format(text, fmt, limits=limits, error=RobotError)
    return robot_from_dict(data, default_name=name)


def robot_from_file(path: str | os.PathLike[str], *, limits: Limits = DEFAULT_LIMITS) -> Robot:
    """The robot in the file ``path``; its name defaults to the file's stem, errors name the file."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise RobotError(f"cannot tell the format of {excerpt(str(path))}: a robot file ends in {', '.join(SUFFIXES)}")
    data, _, _ = read_file(path, limits=limits, error=RobotError, what="robot file")
    return robot_from_dict(data, default_name=path.stem, file=path.name)


def load_robot(source: Robot | str | Path | dict[str, Any]) -> Robot:
    """A robot from a :class:`Robot` (as is), a shipped robot's name, a path or a dict (the
    rules of :func:`~tensegrity_core.schema.resolve_source`); for local use (text from
    elsewhere goes to :func:`robot_from_text`)."""
    if isinstance(source, Robot):
        return source
    found = resolve_source(source, what="robot", shipped=SHIPPED_ROBOTS, error=RobotError, suffixes=SUFFIXES, text=None)
    if found.data is not None:
        return robot_from_dict(found.data)
    assert found.path is not None                 # text is not accepted
    return robot_from_file(found.path)
