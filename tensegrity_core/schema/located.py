"""Parsed containers that remember where they came from.

The YAML reader builds :class:`LocatedDict` and :class:`LocatedList` (plain ``dict`` and
``list`` subclasses, so schemas read them like any parsed data) that carry the 1-based line
of themselves and of each key or item. :func:`line_of` asks any container for a line and
gets ``None`` from containers without lines (dicts built in Python, JSON, TOML);
:func:`plain` drops the lines.
"""

from __future__ import annotations

from typing import Any


class LocatedDict(dict[Any, Any]):
    """A mapping with ``line`` (its own) and ``key_lines`` (key -> line of the key)."""

    __slots__ = ("line", "key_lines")

    def __init__(self, line: int | None = None) -> None:
        super().__init__()
        self.line = line
        self.key_lines: dict[Any, int] = {}


class LocatedList(list[Any]):
    """A sequence with ``line`` (its own) and ``item_lines`` (line of each item)."""

    __slots__ = ("line", "item_lines")

    def __init__(self, line: int | None = None) -> None:
        super().__init__()
        self.line = line
        self.item_lines: list[int] = []


def line_of(container: Any, key: Any = None) -> int | None:
    """The line of ``container[key]`` (of the key, for a mapping), else of ``container``
    itself, else ``None``."""
    if isinstance(container, LocatedDict):
        return container.key_lines.get(key, container.line)
    if isinstance(container, LocatedList):
        if isinstance(key, int) and 0 <= key < len(container.item_lines):
            return container.item_lines[key]
        return container.line
    return None


def plain(value: Any) -> Any:
    """Parsed data with every located mapping and list made a plain ``dict`` and ``list``
    (for documents kept, copied and sent to other processes: a sweep's base)."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value
