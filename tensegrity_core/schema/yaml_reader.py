"""YAML text to plain data, bounded and with line numbers.

Why this is not ``yaml.load(text, Loader=SafeLoader)``: PyYAML's loaders construct values
recursively (deep nesting ends in ``RecursionError``), keep an alias as a shared object that
any later walk expands (a 400-byte "alias bomb" is 10^9 values to a validator or to the
``repr`` in an error message), record no lines in the result, and resolve every plain
scalar through a list of regular expressions (most of the time spent on a large file). So
this reader takes PyYAML's event stream (libyaml's parser, or PyYAML's own when libyaml is
missing) and builds the result in one loop without recursion. While the events arrive it
checks the nesting depth and counts aliases and the values they add against
:class:`~tensegrity_core.schema.limits.Limits`; every mapping and list is a
:class:`~tensegrity_core.schema.located.LocatedDict` / ``LocatedList`` with the lines of
its keys and items; plain scalars that are decimal numbers are converted directly and every
distinct scalar text is resolved once. Everything else (booleans, null, YAML 1.1's other
number forms, timestamps, explicit tags) goes through PyYAML's own resolver and
``SafeConstructor``, so values mean what they mean to ``SafeLoader``, with one change:
YAML 1.1 reads ``7.6e10`` (no dot, no exponent sign) and ``-.5`` as strings; here they are
the numbers they look like. Only one document is read; tags other than the standard
scalar ones and ``!!seq``/``!!map`` are refused. Merge keys (``<<: *defaults``) work.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any, Final, TypeAlias

import yaml
from yaml.events import (
    AliasEvent,
    DocumentStartEvent,
    MappingEndEvent,
    MappingStartEvent,
    ScalarEvent,
    SequenceEndEvent,
    SequenceStartEvent,
    StreamEndEvent,
)
from yaml.nodes import ScalarNode

from tensegrity_core.excerpt import LIBRARY_MESSAGE
from tensegrity_core.schema.errors import SchemaError, clip, excerpt
from tensegrity_core.schema.limits import DEFAULT_LIMITS, Limits
from tensegrity_core.schema.located import LocatedDict, LocatedList

try:
    from yaml._yaml import CParser as _Parser
except ImportError:  # pragma: no cover (PyYAML built without libyaml)
    from yaml.parser import Parser
    from yaml.reader import Reader
    from yaml.scanner import Scanner

    class _Parser(Reader, Scanner, Parser):  # type: ignore[no-redef]  # the same parser in Python
        def __init__(self, stream: str) -> None:
            Reader.__init__(self, stream)
            Scanner.__init__(self)
            Parser.__init__(self)

_INT: Final = re.compile(r"[-+]?(?:0|[1-9][0-9]*)\Z")
_FLOAT: Final = re.compile(r"[-+]?(?:(?:[0-9]+\.[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?|[0-9]+[eE][-+]?[0-9]+)\Z")
_RESOLVER: Final = yaml.resolver.Resolver()
_CONSTRUCTOR: Final = yaml.constructor.SafeConstructor()
_SCALAR_TAGS: Final = {f"tag:yaml.org,2002:{t}" for t in ("str", "int", "float", "bool", "null", "timestamp", "binary")}
_COLLECTION_TAGS: Final = {None, "!", "tag:yaml.org,2002:seq", "tag:yaml.org,2002:map"}
_MERGE_TAG: Final = "tag:yaml.org,2002:merge"

#: ``(reason, line) -> error`` to raise: the caller's error class, located in its file.
Fail: TypeAlias = Callable[[str, "int | None"], SchemaError]


class _Merge:
    """The merge key ``<<`` (its value's keys are merged into the mapping that holds it)."""

    def __repr__(self) -> str:
        return "'<<'"


MERGE: Final = _Merge()
_MISSING: Final = object()


def parse_yaml(text: str, *, limits: Limits = DEFAULT_LIMITS, error: type[SchemaError] = SchemaError,
               file: str | None = None) -> Any:
    """Parse one YAML document into dicts, lists and scalars (mappings and lists located).

    Raises ``error`` (a :class:`SchemaError` class) for invalid YAML, more than one document,
    unsupported tags, duplicate or non-scalar keys, nesting deeper than
    ``limits.max_depth``, more than ``limits.max_aliases`` aliases or aliases that add more
    than ``limits.max_alias_values`` values, an alias inside its own anchor. The size bound
    is the caller's (:func:`tensegrity_core.schema.documents.check_size`). An empty
    document is ``None``.
    """

    def fail(reason: str, line: int | None) -> SchemaError:
        return error(reason, line=line, file=file)

    try:
        get_event = _Parser(text).get_event
    except (TypeError, UnicodeError) as err:
        raise error(f"cannot read the text as YAML: {err}", file=file) from None
    cache: dict[str, Any] = {}
    anchors: dict[str, tuple[Any, int | None]] = {}
    # A frame per open container: [container, is_mapping, key, key_seen, anchor, count_at_start, merges]
    stack: list[list[Any]] = []
    root: Any = None
    obj: Any
    count = aliases = alias_values = documents = 0
    max_depth, max_aliases, max_alias_values = limits.max_depth, limits.max_aliases, limits.max_alias_values
    while True:
        try:
            event = get_event()
        except yaml.YAMLError as err:
            raise _syntax_error(err, text, error, file) from None
        # get_event() gives None only after the stream's end (returned below); both parsers set start_mark
        line = event.start_mark.line + 1  # type: ignore[union-attr]
        is_start = False
        if isinstance(event, ScalarEvent):
            count += 1
            tag = event.tag
            if tag is None or tag == "!":
                if event.implicit[0]:
                    value = event.value
                    obj = cache.get(value, _MISSING)
                    if obj is _MISSING:
                        obj = cache[value] = _plain(value, line, fail)
                else:
                    obj = event.value
            elif tag in _SCALAR_TAGS:
                obj = _construct(tag, event.value, line, fail)
            else:
                raise fail(f"unsupported tag {excerpt(tag)} (only plain data is read)", line)
            if event.anchor is not None:
                anchors[event.anchor] = (obj, 1)
        elif isinstance(event, (MappingStartEvent, SequenceStartEvent)):
            count += 1
            if len(stack) >= max_depth:
                raise fail(f"nested deeper than {max_depth} levels", line)
            if event.tag not in _COLLECTION_TAGS:
                raise fail(f"unsupported tag {excerpt(event.tag)} (only plain mappings and lists are read)",
                           line)
            obj = LocatedDict(line) if isinstance(event, MappingStartEvent) else LocatedList(line)
            if event.anchor is not None:
                anchors[event.anchor] = (obj, None)      # open: an alias to it now is recursive
            is_start = True
        elif isinstance(event, (MappingEndEvent, SequenceEndEvent)):
            container, is_map, _, _, anchor, start, merges = stack.pop()
            if merges:
                _merge(container, merges, fail)
            if anchor is not None:
                anchors[anchor] = (container, count - start)
            continue
        elif isinstance(event, AliasEvent):
            entry = None if event.anchor is None else anchors.get(event.anchor)
            if entry is None:
                raise fail(f"undefined alias {excerpt(event.anchor)}", line)
            obj, size = entry
            if size is None:
                raise fail(f"alias {excerpt(event.anchor)} inside its own anchor (a recursive value)",
                           line)
            aliases += 1
            alias_values += size
            if aliases > max_aliases:
                raise fail(f"more than {max_aliases} aliases", line)
            if alias_values > max_alias_values:
                raise fail(f"aliases expand to more than {max_alias_values} values", line)
            count += size
        elif isinstance(event, DocumentStartEvent):
            documents += 1
            if documents > 1:
                raise fail("more than one YAML document ('---' starts a second one)", line)
            continue
        elif isinstance(event, StreamEndEvent):
            return root
        else:                                           # stream start, document end
            continue

        # Put obj where it belongs: the root, a list item, a mapping key or a mapping value.
        if not stack:
            root = obj
        else:
            frame = stack[-1]
            container = frame[0]
            if not frame[1]:
                container.append(obj)
                container.item_lines.append(line)
            elif frame[3]:
                frame[3] = False
                if frame[2] is MERGE:
                    frame[6].append((obj, line))
                else:
                    container[frame[2]] = obj
            else:
                if is_start or isinstance(obj, (dict, list)):
                    raise fail("a mapping key must be a single value, not a mapping or a list", line)
                if obj is not MERGE:
                    try:
                        first = container.key_lines.get(obj)
                    except TypeError:
                        raise fail(f"a mapping key must be a single value, got {excerpt(obj)}",
                                   line) from None
                    if first is not None:
                        raise fail(f"duplicate key {excerpt(obj)} (first at line {first})", line)
                    container.key_lines[obj] = line
                frame[2] = obj
                frame[3] = True
        if is_start:
            stack.append([obj, isinstance(obj, LocatedDict), None, False, event.anchor, count - 1, []])


def _plain(value: str, line: int, fail: Fail) -> Any:
    """A plain (unquoted, untagged) scalar's value."""
    if _FLOAT.match(value):
        return float(value)
    if _INT.match(value):
        try:
            return int(value)
        except ValueError:
            raise fail(f"the integer {excerpt(value)} has too many digits", line) from None
    tag = plain_scalar_tag(value)
    if tag == _MERGE_TAG:
        return MERGE
    return _construct(tag, value, line, fail)


def plain_scalar_tag(value: str) -> str:
    """The tag PyYAML's resolver (``SafeLoader``'s rules) gives the plain scalar ``value``,
    e.g. ``"tag:yaml.org,2002:str"`` (the writer keeps a string plain only when it reads back
    as one)."""
    tag: str = _RESOLVER.resolve(ScalarNode, value, (True, False))  # type: ignore[no-untyped-call]  # unannotated in types-PyYAML
    return tag


def _construct(tag: str, value: str, line: int, fail: Fail) -> Any:
    try:
        return _CONSTRUCTOR.yaml_constructors[tag](_CONSTRUCTOR, ScalarNode(tag, value))
    except (ValueError, TypeError, OverflowError, yaml.YAMLError):
        raise fail(f"cannot read {excerpt(value)} as {tag.rsplit(':', 1)[-1]}", line) from None


def _merge(container: LocatedDict, merges: list[tuple[Any, int]], fail: Fail) -> None:
    """``<<: mapping`` or ``<<: [mapping, ...]``: keys the mapping lacks are taken from
    them, earlier mappings first (YAML's merge key)."""
    for value, line in merges:
        sources = value if isinstance(value, list) else [value]
        for source in sources:
            if not isinstance(source, dict):
                raise fail(f"'<<' merges mappings, got {excerpt(source)}", line)
            for key, item in source.items():
                if key not in container:
                    container[key] = item
                    container.key_lines[key] = line


def _syntax_error(err: yaml.YAMLError, text: str, error: type[SchemaError], file: str | None) -> SchemaError:
    if isinstance(err, yaml.MarkedYAMLError):
        mark = err.problem_mark or err.context_mark
        problem = err.problem or err.context or "syntax error"
        return error(f"invalid YAML: {clip(problem, LIBRARY_MESSAGE)}", line=mark.line + 1 if mark else None, file=file)
    if isinstance(err, yaml.reader.ReaderError):
        line = text.count("\n", 0, max(0, err.position)) + 1 if isinstance(err.position, int) else None
        return error(f"invalid YAML: {clip(err.reason, LIBRARY_MESSAGE)}", line=line, file=file)
    return error(f"invalid YAML: {clip(err, LIBRARY_MESSAGE)}", file=file)
