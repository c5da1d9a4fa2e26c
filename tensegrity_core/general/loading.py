"""Structure descriptions from text, files and shipped examples: the entry points.

Each entry point takes one kind of source and says so in its name; none guesses whether a
string is a file name or a description:

- :func:`structure_from_text`: description text (YAML, JSON or TOML). The one to use for
  text from elsewhere (a service request): it never opens a file.
- :func:`structure_from_file`: a file (``.yaml``/``.yml``, ``.json``, ``.toml``, ``.npz``).
- :func:`load_example`: a shipped example, by name.
- :func:`~tensegrity_core.general.structure_schema.structure_from_dict`: parsed data.
- :func:`load_structure`: the convenience for local use (a Python session, the CLI): a
  :class:`Structure`, a dict, a path, a shipped example's name or text, told apart by
  :func:`~tensegrity_core.schema.resolve_source`. Never give it text from elsewhere: a
  one-line "description" would name a file on this machine.

Text is bounded by :class:`~tensegrity_core.schema.Limits` (size, nesting, aliases) before
and while it is parsed; ``max_members`` refuses larger structures before they are built.
Errors are :class:`StructureError` with the entry, the line (YAML; JSON errors are located
by reading the text again as YAML, which JSON is) and the file's name.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Final

from tensegrity_core.general.examples import SHIPPED_EXAMPLES, example_path
from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.general.structure_schema import structure_from_dict
from tensegrity_core.schema import DEFAULT_LIMITS, Limits, parse_text_format, parse_yaml, read_file, resolve_source

#: File suffixes of structure descriptions.
SUFFIXES: Final = (".yaml", ".yml", ".json", ".toml", ".npz")


def structure_from_text(text: str, fmt: str | None = None, *, limits: Limits = DEFAULT_LIMITS,
                        max_members: int | None = None, name: str = "") -> Structure:
    """The structure described by ``text`` (``fmt``: ``"yaml"``, ``"json"``, ``"toml"`` or
    None to guess: JSON if it starts with ``{``, TOML if its first line looks like TOML).
    ``name`` is the structure's name when the text gives none."""
    data, fmt = parse_text_format(text, fmt, limits=limits, error=StructureError)
    return _build(data, text, fmt, limits, max_members, name, file=None)


def structure_from_file(path: str | os.PathLike[str], *, limits: Limits = DEFAULT_LIMITS, max_members: int | None = None) -> Structure:
    """The structure in the file ``path``: a description (``.yaml``, ``.yml``, ``.json``,
    ``.toml``) or the array file ``.npz`` (see :mod:`~tensegrity_core.general.structure_npz`).
    Its name defaults to the file's stem; errors name the file."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise StructureError(f"cannot tell the format of {str(path)!r}: a structure file ends in "
                             f"{', '.join(SUFFIXES)}")
    if suffix == ".npz":
        from tensegrity_core.general.structure_npz import read_npz

        return read_npz(path, limits=limits, max_members=max_members)
    data, text, fmt = read_file(path, limits=limits, error=StructureError, what="structure file")
    return _build(data, text, fmt, limits, max_members, path.stem, file=path.name)


def _build(data: Any, text: str, fmt: str | None, limits: Limits, max_members: int | None, name: str,
           file: str | None) -> Structure:
    try:
        return structure_from_dict(data, default_name=name, max_members=max_members)
    except StructureError as err:
        if err.line is None and fmt == "json" and "\n" in text.strip():     # one line: nothing to locate
            err = _located_by_yaml(text, limits, max_members, name) or err
        raise err.located(file=file) from None


def _located_by_yaml(text: str, limits: Limits, max_members: int | None, name: str) -> StructureError | None:
    """The same error from the text read as YAML (JSON is YAML), which knows lines."""
    try:
        structure_from_dict(parse_yaml(text, limits=limits, error=StructureError), default_name=name,
                            max_members=max_members)
    except StructureError as err:
        return err
    return None


def load_example(name: str) -> Structure:
    """The shipped example ``name`` (e.g. ``"tensegrity_table"``) as a structure."""
    return structure_from_file(example_path(name))


def load_structure(source: object) -> Structure:
    """A :class:`Structure` from a Structure (returned as is), a dict, a path (``Path``, or a
    ``str`` without a line break that names an existing file), a shipped example's name, or
    description text (the rules of :func:`~tensegrity_core.schema.resolve_source`). For
    local use only: see the module's docstring."""
    if isinstance(source, Structure):
        return source
    found = resolve_source(source, what="structure", shipped=SHIPPED_EXAMPLES, error=StructureError,
                           suffixes=SUFFIXES, text="YAML, JSON or TOML text")
    if found.data is not None:
        return structure_from_dict(found.data)
    if found.text is not None:
        return structure_from_text(found.text)
    assert found.path is not None                 # the one kind left
    return structure_from_file(found.path)
