"""Key paths: where a value sits in a nested description.

A key path is a tuple of mapping keys (str) and list positions (int), written
``effects[2].fold_limit.restitution``. :func:`get_at` and :func:`set_at` follow one into a
parsed description; a key that is not there is named with the closest existing key.
Keys containing ``.`` or ``[`` cannot be written in the text form.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any, Final

from tensegrity_core.schema.errors import KeyPath, SchemaError, excerpt, suggest, type_name
from tensegrity_core.schema.located import line_of

_PART: Final = re.compile(r"([^.\[\]]+)|\[(-?[0-9]+)\]")


def parse_key_path(text: object) -> tuple[str | int, ...]:
    """``"effects[2].fold_limit"`` -> ``("effects", 2, "fold_limit")``; ``""`` -> ``()``
    (:func:`~tensegrity_core.schema.errors.format_key_path` writes it back)."""
    if not isinstance(text, str):
        raise SchemaError(f"a key path must be a string like 'model.params.k', got {excerpt(text)}")
    out: list[str | int] = []
    pos = 0
    while pos < len(text):
        if out and text[pos] == ".":
            pos += 1
        elif out and text[pos] != "[":
            pos = -1
        m = _PART.match(text, pos) if pos >= 0 else None
        if m is None:
            raise SchemaError(f"cannot read the key path {excerpt(text)}: write keys separated by '.' "
                              f"and list positions as [i], e.g. 'effects[2].fold_limit'")
        out.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        pos = m.end()
    return tuple(out)


def get_at(doc: Any, path: str | Iterable[object], *, error: type[SchemaError] | None = None) -> Any:
    """The value at ``path`` (a tuple or its text form) in ``doc``; a missing key raises
    ``error`` (default :class:`SchemaError`) naming the path, the closest key and the line."""
    parts = parse_key_path(path) if isinstance(path, str) else tuple(path)
    value = doc
    for depth, part in enumerate(parts):
        value = _step(value, part, parts[:depth + 1], error)
    return value


def set_at(doc: Any, path: str | Iterable[object], value: Any, *, error: type[SchemaError] | None = None) -> Any:
    """A copy of ``doc`` with the value at ``path`` replaced by ``value`` (only the
    containers on the path are copied; ``doc`` is not changed). The last key of a mapping
    may be new; every key before it must exist."""
    parts = parse_key_path(path) if isinstance(path, str) else tuple(path)
    if not parts:
        return value
    head, rest = parts[0], parts[1:]
    if isinstance(doc, dict):
        if rest or head in doc:
            inner = set_at(_step(doc, head, (head,), error), rest, value, error=error) if rest else value
        else:
            inner = value
        mapping = dict(doc)
        mapping[head] = inner
        return mapping
    child = _step(doc, head, (head,), error)
    assert isinstance(head, int)              # _step accepts only a position in a list here
    items = list(doc)
    items[head] = set_at(child, rest, value, error=error)
    return items


def _step(value: Any, part: object, where: KeyPath, error: type[SchemaError] | None) -> Any:
    error = error or SchemaError
    parent = where[:-1]
    if isinstance(value, dict):
        if part in value:
            return value[part]
        raise error(f"no key {part!r}{suggest(part, list(value))}; keys: "
                    f"{', '.join(map(str, list(value)[:20]))}", key=parent, line=line_of(value, None))
    if isinstance(value, list):
        if isinstance(part, int) and not isinstance(part, bool) and -len(value) <= part < len(value):
            return value[part]
        raise error(f"no item [{part}] in a list of {len(value)}", key=parent, line=line_of(value, None))
    raise error(f"cannot look up {part!r} in {type_name(value)}", key=parent)
