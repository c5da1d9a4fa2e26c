"""Key paths: where a value sits in a nested description, and how to reach it.

A key path is a tuple of mapping keys and list positions, outermost first
(:data:`~tensegrity_core.schema.errors.KeyPath`), written ``effects[2].fold_limit.restitution``
(:func:`parse_key_path` reads the text, :func:`~tensegrity_core.schema.errors.format_key_path`
writes it). A *pattern* (what a sweep varies) may also select list entries by name::

    model.params.k                 a key of a mapping
    loads.c1[2]                    an item of a list, by position (0-based)
    members[side*].rest_length     every list item whose name matches the glob ``side*``
    effects[damping].beta          the options of an effect (listed as ``damping`` or
                                   ``{damping: {...}}``)

A name selector matches list items that are mappings with a ``name`` key (members, rigid
bodies), one-key mappings by their key (a scene's effects with options) and plain strings
(effects without options, which become ``{name: {}}``, the same effect). It selects every
match, so one pattern can stand for a group of entries. :func:`resolve` turns a pattern into
the key paths it stands for in one document, checking every step.

Reading and writing one key path, the names say whether the document changes:
:func:`get_at` reads, :func:`exists` tests, :func:`with_value_at` returns a changed copy
(only the containers on the path are copied) and :func:`set_in_place` changes the document
itself. A key that is not there is named with the closest existing key (and its line, for
YAML). Keys containing ``.`` or ``[`` cannot be written in the text form.
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Iterable
from typing import Any, Final, Literal, TypeAlias

from tensegrity_core.schema.errors import KeyPath, SchemaError, excerpt, format_key_path, suggest, type_name
from tensegrity_core.schema.located import line_of

#: One step of a pattern: ``("key", name)``, ``("index", n)`` or ``("select", glob)``.
Token: TypeAlias = tuple[Literal["key", "index", "select"], Any]

_SEGMENT: Final = re.compile(r"([^.\[\]]*)((?:\[[^\[\]]*\])*)")
_POSITION: Final = re.compile(r"-?[0-9]+")


class KeyPathError(SchemaError):
    """A key path or pattern is malformed, or does not lead anywhere in the document."""


def _tokens(text: str) -> list[Token]:
    """The steps of ``text`` (keys, positions and selectors); a malformed text raises
    :class:`KeyPathError`."""
    out: list[Token] = []
    for n, part in enumerate(text.split(".")):
        m = _SEGMENT.fullmatch(part)
        if m is None or (not m.group(1) and (n > 0 or not m.group(2))):
            raise KeyPathError(f"cannot read the key path {excerpt(text)}: write keys separated by '.' and list "
                               f"positions as [i], e.g. 'effects[2].fold_limit'")
        if m.group(1):
            out.append(("key", m.group(1)))
        for sel in re.findall(r"\[([^\[\]]*)\]", m.group(2)):
            sel = sel.strip()
            if not sel:
                raise KeyPathError(f"cannot read the key path {excerpt(text)}: empty selector []")
            out.append(("index", int(sel)) if _POSITION.fullmatch(sel) else ("select", sel))
    return out


def parse_key_path(text: object) -> KeyPath:
    """``"effects[2].fold_limit"`` -> ``("effects", 2, "fold_limit")``; ``""`` -> ``()``."""
    if not isinstance(text, str):
        raise KeyPathError(f"a key path must be a string like 'model.params.k', got {excerpt(text)}")
    if not text:
        return ()
    out: list[object] = []
    for kind, arg in _tokens(text):
        if kind == "select":
            raise KeyPathError(f"cannot read the key path {excerpt(text)}: [{arg}] is no list position (a key "
                               f"path names one place; selectors by name are for sweeps' patterns)")
        out.append(arg)
    return tuple(out)


def parse_pattern(text: object) -> tuple[Token, ...]:
    """``"members[side*].rest_length"`` -> ``(("key", "members"), ("select", "side*"),
    ("key", "rest_length"))``; positions give ``("index", n)`` (counted from 0)."""
    if not isinstance(text, str) or not text.strip():
        raise KeyPathError(f"a key path must be a non-empty string, got {excerpt(text)}")
    tokens = _tokens(text)
    for kind, arg in tokens:
        if kind == "index" and arg < 0:
            raise KeyPathError(f"list positions count from 0, got [{arg}] in {excerpt(text)}")
    return tuple(tokens)


def _as_path(path: str | Iterable[object]) -> KeyPath:
    return parse_key_path(path) if isinstance(path, str) else tuple(path)


def get_at(doc: Any, path: str | Iterable[object], *, error: type[SchemaError] = KeyPathError) -> Any:
    """The value at ``path`` (a key path or its text) in ``doc``; a missing key raises
    ``error`` naming the path, the closest key and the line."""
    parts = _as_path(path)
    value = doc
    for depth, part in enumerate(parts):
        value = _step(value, part, parts[:depth], error)
    return value


def exists(doc: Any, path: str | Iterable[object]) -> bool:
    """Whether ``path`` leads to a value of ``doc`` (its last key, too)."""
    try:
        get_at(doc, path)
    except KeyPathError:
        return False
    return True


def with_value_at(doc: Any, path: str | Iterable[object], value: Any, *,
                  error: type[SchemaError] = KeyPathError) -> Any:
    """A copy of ``doc`` with the value at ``path`` replaced by ``value``; ``doc`` is not
    changed (only the containers on the path are copied, the rest is shared). The last key
    of a mapping may be new; every key before it must exist."""
    parts = _as_path(path)
    if not parts:
        return value
    head, rest = parts[0], parts[1:]
    if isinstance(doc, dict):
        inner = with_value_at(_step(doc, head, (), error), rest, value, error=error) if rest else value
        mapping = dict(doc)
        mapping[head] = inner
        return mapping
    child = _step(doc, head, (), error)
    items = list(doc)
    items[_position(head)] = with_value_at(child, rest, value, error=error)
    return items


def set_in_place(doc: Any, path: str | Iterable[object], value: Any, *,
                 error: type[SchemaError] = KeyPathError) -> None:
    """Write ``value`` at ``path`` in ``doc`` itself (the containers on the path must exist;
    the last key of a mapping may be new)."""
    parts = _as_path(path)
    if not parts:
        raise error("an empty key path names the whole document, which cannot be set in place")
    parent = get_at(doc, parts[:-1], error=error)
    last = parts[-1]
    if isinstance(parent, list):
        _step(parent, last, parts[:-1], error)          # an existing position
        parent[_position(last)] = value
    elif isinstance(parent, dict):
        parent[last] = value
    else:
        raise error(f"cannot set {excerpt(last)} in {type_name(parent)}", key=parts[:-1])


def _position(part: object) -> int:
    assert isinstance(part, int)          # _step accepted only a list position for a list
    return part


def _step(value: Any, part: object, parent: KeyPath, error: type[SchemaError]) -> Any:
    """``value[part]``, or ``error`` located at ``parent`` (the key path of ``value``)."""
    if isinstance(value, dict):
        if part in value:
            return value[part]
        raise error(f"no key {excerpt(part)}{suggest(part, list(value))}; keys: "
                    f"{', '.join(map(str, list(value)[:20])) or '(none)'}", key=parent, line=line_of(value, None))
    if isinstance(value, list):
        if isinstance(part, int) and not isinstance(part, bool) and -len(value) <= part < len(value):
            return value[part]
        raise error(f"no item [{part}] in a list of {len(value)}", key=parent, line=line_of(value, None))
    raise error(f"cannot look up {excerpt(part)} in {type_name(value)}", key=parent)


def _item_name(item: object) -> tuple[str, Any] | None:
    """(name, child key or None) of a list item for name selectors, or None."""
    if isinstance(item, dict) and isinstance(item.get("name"), str):
        return item["name"], None
    if isinstance(item, dict) and len(item) == 1:
        key = next(iter(item))
        return str(key), key
    if isinstance(item, str):
        return item, item
    return None


def resolve(document: Any, pattern: str, *, need_number: bool = False) -> list[KeyPath]:
    """The key paths that ``pattern`` stands for in ``document``.

    Every step but the last must exist; the last key may be new in a mapping (a parameter the
    document leaves at its default) unless ``need_number`` (the value is scaled, so it must
    exist and be a number). Plain-string list items that a name selector passes through are
    rewritten in ``document`` as ``{name: {}}`` (the same entry with empty options). Errors
    are :class:`KeyPathError` naming the place in words (the caller locates the pattern)."""
    tokens = parse_pattern(pattern)
    out: list[KeyPath] = []

    def walk(node: Any, i: int, prefix: KeyPath) -> None:
        kind, arg = tokens[i]
        last = i == len(tokens) - 1
        where = format_key_path(prefix) or "the document"
        if kind == "key":
            if not isinstance(node, dict):
                raise KeyPathError(f"{where} is not a mapping, so it has no key {arg!r}")
            if arg not in node and (not last or need_number):
                raise KeyPathError(f"{where} has no key {arg!r}{suggest(arg, node)}; keys: "
                                   f"{', '.join(map(str, node)) or '(none)'}")
            nxt = [(node.get(arg), prefix + (arg,))]
        elif kind == "index":
            if not isinstance(node, list):
                raise KeyPathError(f"{where} is not a list, so it has no item [{arg}]")
            if arg >= len(node):
                raise KeyPathError(f"{where} has {len(node)} item(s), so no item [{arg}]")
            nxt = [(node[arg], prefix + (arg,))]
        else:
            nxt = _select(node, arg, prefix, where, pattern, last)
        for child, loc in nxt:
            if last:
                if need_number and (isinstance(child, bool) or not isinstance(child, (int, float))):
                    raise KeyPathError(f"{format_key_path(loc)} is {excerpt(child)}, not a number to scale")
                out.append(loc)
            else:
                walk(child, i + 1, loc)

    walk(document, 0, ())
    return out


def _select(node: Any, glob: str, prefix: KeyPath, where: str, pattern: str, last: bool) -> list[tuple[Any, KeyPath]]:
    """The entries of the list ``node`` whose names match ``glob`` (see :func:`resolve`)."""
    if not isinstance(node, list):
        raise KeyPathError(f"{where} is not a list, so [{glob}] selects nothing")
    if last:
        raise KeyPathError(f"[{glob}] selects entries; say which key of them to vary (e.g. {pattern}.rest_length)")
    names: list[str] = []
    out: list[tuple[Any, KeyPath]] = []
    for j, item in enumerate(node):
        named = _item_name(item)
        if named is None:
            continue
        names.append(named[0])
        if not fnmatch.fnmatchcase(named[0], glob):
            continue
        if isinstance(item, str):
            node[j] = item = {item: {}}
        if named[1] is None:
            out.append((item, prefix + (j,)))
        else:
            if item[named[1]] is None:
                item[named[1]] = {}
            out.append((item[named[1]], prefix + (j, named[1])))
    if not out:
        shown = ", ".join(names[:12]) + (", ..." if len(names) > 12 else "")
        groups = sorted({re.sub(r"[_\d]+$", "", n) + "*" for n in names} - set(names))
        raise KeyPathError(f"no entry of {where} matches [{glob}]{suggest(glob, names + groups)}; "
                           f"entries: {shown or '(none with a name)'}")
    return out
