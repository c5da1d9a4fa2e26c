"""Bounds on one document, checked before and while it is parsed.

A description from elsewhere (a service request, a downloaded file) must not be able to
make the reader use unbounded memory or time: its size is checked before parsing, its
nesting depth and its aliases while parsing. Without aliases a document cannot hold more
values than it has bytes, so the size bound also bounds the number of values; aliases are
the one way a short text stands for a large value (an "alias bomb": 400 bytes that expand
to 10^9 values), so both their number and the number of values they add are bounded.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final


@dataclass(frozen=True)
class Limits:
    """``max_bytes``: longest text (UTF-8 bytes) or file; ``max_depth``: deepest nesting of
    mappings and lists; ``max_aliases``: aliases (``*name``) in one document;
    ``max_alias_values``: values added by expanding all aliases together."""

    max_bytes: int = 256 * 2**20
    max_depth: int = 64
    max_aliases: int = 100
    max_alias_values: int = 10_000


#: What local files get unless a caller asks for less.
DEFAULT_LIMITS: Final = Limits()
