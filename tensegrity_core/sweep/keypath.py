"""Key paths into a parsed scene or structure document (plain dicts and lists).

Syntax: keys joined by dots, each optionally followed by selectors in brackets::

    model.params.k                 a key of a mapping
    loads.c1[2]                    an item of a list, by position (0-based)
    members[side*].rest_length     every list item whose name matches the glob ``side*``
    effects[damping].beta          the options of an effect (listed as ``damping`` or
                                   ``{damping: {...}}``)

A name selector matches list items that are mappings with a ``name`` key (members, rigid
bodies), one-key mappings by their key (a scene's effects with options) and plain strings
(effects without options, which become ``{name: {}}``, the same effect). It selects every
match, so one key path can stand for a group of entries (a group's rest-length factor).
:func:`resolve` turns a key path into the concrete locations it stands for in one document,
checking every step (with a suggestion for a misspelt key); :func:`get_at` and
:func:`set_at` read and write one location.
"""

from __future__ import annotations

import fnmatch
import re
from typing import Any

from tensegrity_core.schema.errors import suggest

#: A concrete location: mapping keys (str) and list positions (int) from the root.
Location = tuple[str | int, ...]
#: A parsed key path step: ``("key", name)``, ``("index", n)`` or ``("select", glob)``.
Token = tuple[str, Any]

_SEGMENT = re.compile(r"([^.\[\]]+)((?:\[[^\[\]]*\])*)")


class KeyPathError(ValueError):
    """A key path is malformed or does not lead anywhere in the document."""


def parse(text: str) -> tuple[Token, ...]:
    """``"members[side*].rest_length"`` -> ``(("key", "members"), ("select", "side*"),
    ("key", "rest_length"))``; positions give ``("index", n)``."""
    if not isinstance(text, str) or not text.strip():
        raise KeyPathError(f"a key path must be a non-empty string, got {text!r}")
    tokens: list[Token] = []
    for part in text.split("."):
        m = _SEGMENT.fullmatch(part)
        if m is None:
            raise KeyPathError(f"malformed key path {text!r} at {part!r} (expected key, key[0] or key[name*])")
        tokens.append(("key", m.group(1)))
        for sel in re.findall(r"\[([^\[\]]*)\]", m.group(2)):
            sel = sel.strip()
            if not sel:
                raise KeyPathError(f"empty selector [] in key path {text!r}")
            if re.fullmatch(r"-?\d+", sel):
                if int(sel) < 0:
                    raise KeyPathError(f"list positions count from 0, got [{sel}] in {text!r}")
                tokens.append(("index", int(sel)))
            else:
                tokens.append(("select", sel))
    return tuple(tokens)


def format_location(loc: Location) -> str:
    """``("members", 3, "rest_length")`` -> ``"members[3].rest_length"``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out


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


def resolve(document: Any, text: str, *, need_number: bool = False) -> list[Location]:
    """The concrete locations of key path ``text`` in ``document``.

    Every step but the last must exist; the last key may be new in a mapping (a parameter the
    document leaves at its default) unless ``need_number`` (the value is scaled, so it must
    exist and be a number). Plain-string list items that a name selector passes through are
    rewritten in ``document`` as ``{name: {}}`` (the same entry with empty options)."""
    tokens = parse(text)
    out: list[Location] = []

    def walk(node: Any, i: int, prefix: Location) -> None:
        kind, arg = tokens[i]
        last = i == len(tokens) - 1
        where = format_location(prefix) or "the document"
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
            if not isinstance(node, list):
                raise KeyPathError(f"{where} is not a list, so [{arg}] selects nothing")
            if last:
                raise KeyPathError(f"[{arg}] selects entries; say which key of them to vary "
                                   f"(e.g. {text}.rest_length)")
            names: list[str] = []
            nxt = []
            for j, item in enumerate(node):
                named = _item_name(item)
                if named is None:
                    continue
                names.append(named[0])
                if not fnmatch.fnmatchcase(named[0], arg):
                    continue
                if isinstance(item, str):
                    node[j] = item = {item: {}}
                if named[1] is None:
                    nxt.append((item, prefix + (j,)))
                else:
                    if item[named[1]] is None:
                        item[named[1]] = {}
                    nxt.append((item[named[1]], prefix + (j, named[1])))
            if not nxt:
                shown = ", ".join(names[:12]) + (", ..." if len(names) > 12 else "")
                groups = sorted({re.sub(r"[_\d]+$", "", n) + "*" for n in names} - set(names))
                raise KeyPathError(f"no entry of {where} matches [{arg}]{suggest(arg, names + groups)}; "
                                   f"entries: {shown or '(none with a name)'}")
        for child, loc in nxt:
            if last:
                if need_number and (isinstance(child, bool) or not isinstance(child, (int, float))):
                    raise KeyPathError(f"{format_location(loc)} is {child!r}, not a number to scale")
                out.append(loc)
            else:
                walk(child, i + 1, loc)

    walk(document, 0, ())
    return out


def get_at(document: Any, loc: Location) -> Any:
    """The value at ``loc``."""
    node = document
    for part in loc:
        node = node[part]
    return node


def set_at(document: Any, loc: Location, value: Any) -> None:
    """Write ``value`` at ``loc`` (the parent must exist)."""
    get_at(document, loc[:-1])[loc[-1]] = value
