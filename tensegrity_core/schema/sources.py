"""What a "name, path, text or dict" argument is: the one resolver every loader uses.

The convenience loaders for local use (``load_scene``, ``load_structure``, ``load_sweep``,
the exporter's sources, a sweep's base, a scene's structure) accept one argument that may
be a shipped file's name, a path, description text or parsed data. :func:`resolve_source`
decides which, by the same rules everywhere:

1. a ``dict`` is parsed data;
2. a ``Path`` is a file (relative to ``folder`` when one is given), which must exist;
3. a ``str`` without a line break is a file when one of that name exists (relative to
   ``folder``, else the current folder), else a shipped file of that name; failing both, a
   ``str`` ending in one of the format's suffixes is a missing file (named, with the closest
   shipped name);
4. any other ``str`` is text when text is accepted and it can be a description (a line
   break, or one of ``:``, ``=``, ``{``); else it names nothing, which is said with the
   closest shipped name and the list of them.

Text from elsewhere (a service request) must never come here: a one-line "description"
would name a file on this machine. Such callers use the ``*_from_text`` entry points.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from tensegrity_core.schema.errors import excerpt, suggest
from tensegrity_core.schema.shipped import ShippedFiles

#: Characters without which a one-line string cannot be a description (YAML, JSON, TOML).
_DESCRIPTION_MARKS = (":", "=", "{")


@dataclass(frozen=True)
class Source:
    """What :func:`resolve_source` found: ``kind`` ``"path"`` (``path``; ``shipped`` is the
    shipped folder it was found in by name, or None), ``"text"`` (``text``) or ``"data"``
    (``data``)."""

    kind: Literal["path", "text", "data"]
    path: Path | None = None
    text: str | None = None
    data: dict[Any, Any] | None = None
    shipped: ShippedFiles | None = None


def resolve_source(source: object, *, what: str, shipped: ShippedFiles | Sequence[ShippedFiles],
                   error: Callable[[str], Exception], suffixes: Sequence[str] = (".yaml", ".yml"),
                   folder: Path | None = None, text: str | None = "YAML text", data: bool = True) -> Source:
    """The :class:`Source` that ``source`` stands for (see the module's docstring).

    ``what`` names the format in messages (``"scene"``); ``shipped``: the shipped files whose
    names are accepted, searched in order; ``error`` makes the exception of a refusal;
    ``folder``: where relative paths start (None: the current folder); ``text``: how text is
    called in messages (``"YAML text"``), or None when text is not accepted; ``data``:
    whether parsed data (a dict) is."""
    folders = (shipped,) if isinstance(shipped, ShippedFiles) else tuple(shipped)
    if isinstance(source, dict) and data:
        return Source("data", data=source)
    if isinstance(source, Path):
        path = source if folder is None or source.is_absolute() else folder / source
        if not _is_file(path):
            _refuse_if_not_regular(path, error)
            raise error(f"{what} file not found: {excerpt(str(path))}{_suggestion(path.stem, folders, what)}")
        return Source("path", path=path)
    if isinstance(source, str):
        one_line = "\n" not in source
        path = Path(source) if folder is None else folder / source
        if one_line and _is_file(path):
            return Source("path", path=path)
        for files in folders:
            if one_line and source in files.names():
                return Source("path", path=files.path(source), shipped=files)
        if one_line:
            _refuse_if_not_regular(path, error)
        kinds = " or ".join(dict.fromkeys(f.what for f in folders))
        if text is None:
            raise error(f"no {what} file {excerpt(str(path))} and no shipped {kinds} {excerpt(source)}"
                        f"{suggest(source, _names(folders))}; {_listing(folders)}")
        if one_line and source.lower().endswith(tuple(suffixes)):
            raise error(f"{what} file not found: {excerpt(str(path))}{_suggestion(path.stem, folders, what)}")
        if not one_line or any(mark in source for mark in _DESCRIPTION_MARKS):
            return Source("text", text=source)
        raise error(f"{excerpt(source)} is neither a shipped {kinds}{suggest(source, _names(folders))} "
                    f"({_listing(folders)}), an existing {what} file nor {text}")
    accepted = ["a name", "a path"] + ([text] if text is not None else []) + (["a dict"] if data else [])
    raise error(f"cannot load a {what} from a {type(source).__name__}; give {', '.join(accepted[:-1])} or "
                f"{accepted[-1]}")


def _refuse_if_not_regular(path: Path, error: Callable[[str], Exception]) -> None:
    """Refuse a path that exists but is no regular file (a fifo, a device, a folder), which
    "not found" would misdescribe."""
    try:
        exists = path.exists()
    except OSError:                       # e.g. a name longer than the system allows
        exists = False
    if exists:
        raise error(f"{excerpt(str(path))} is not a regular file")


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except OSError:                       # e.g. a name longer than the system allows
        return False


def _names(folders: Sequence[ShippedFiles]) -> list[str]:
    return [name for files in folders for name in files.names()]


def _listing(folders: Sequence[ShippedFiles]) -> str:
    return "; ".join(f"{files.listing}: {', '.join(files.names())}" for files in folders)


def _suggestion(stem: str, folders: Sequence[ShippedFiles], what: str) -> str:
    return suggest(stem, _names(folders), f" (a shipped {what}: {{!r}}?)")
