"""Errors of the bag tools."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import excerpt

T = TypeVar("T")


class BagError(TensegrityError):
    """A bag cannot be written, read, repaired or played; the message names the path or topic."""


def decoded(decode: Callable[[bytes], T], data: bytes, where: str) -> T:
    """``decode(data)``, or a one-line BagError saying ``where`` the message is (bag, topic,
    which message) when its bytes are not a message of its type: a record cut short or
    overwritten in a damaged file, which the CDR reader meets as a ``struct.error`` or an
    ``IndexError`` deep in its own code."""
    try:
        return decode(data)
    except Exception as err:      # whatever the CDR reader raises on bytes that are not its type
        raise BagError(f"{where} cannot be decoded ({len(data)} bytes: "
                       f"{excerpt(str(err) or type(err).__name__)})") from None
