"""Bounded renderings of outside values for log lines and error messages.

A value that came from outside (a message field, a request, a file) may be megabytes long
or nested a million levels deep; quoting it whole makes a log line or an error message as
large as the input (a 64 KiB actuator name gave a 65 kB warning). :func:`excerpt` shows at
most ``limit`` characters of it and says how long the original was, so the reader still
sees which value was meant. Built on :mod:`reprlib`, whose depth and width limits keep even
deep or shared (YAML alias) structures cheap to render.
"""

from __future__ import annotations

import reprlib
from typing import Final

#: Characters of an outside value quoted in a message (the quote marks not counted).
DEFAULT_LIMIT: Final = 60

class _Repr(reprlib.Repr):
    """reprlib with numpy scalars shown as the Python numbers they hold (numpy >= 2 reprs
    ``np.float64(-1.0)``, which reads as code in a user's message)."""

    def repr1(self, x: object, level: int) -> str:
        if getattr(x, "ndim", None) == 0 and hasattr(x, "item"):
            x = x.item()
        return super().repr1(x, level)


_REPR = _Repr()
_REPR.maxlevel = 3
_REPR.maxstring = DEFAULT_LIMIT
_REPR.maxother = DEFAULT_LIMIT
for _name in ("maxlist", "maxtuple", "maxdict", "maxset", "maxfrozenset", "maxdeque", "maxarray"):
    setattr(_REPR, _name, 4)


def excerpt(value: object, limit: int = DEFAULT_LIMIT) -> str:
    """``repr(value)`` cut to about ``limit`` characters, marked with ``…`` when it was cut.

    A string or bytes value that was cut also says its full length (``"… (N characters)"``,
    ``"… (N bytes)"``); any other value is rendered by :mod:`reprlib` (at most 3 levels
    deep, 4 items per container) before it is cut. The result is at most about
    ``limit`` + 25 characters long, whatever the value. numpy scalars show as plain numbers
    (``inf``, not ``np.float64(inf)``).
    """
    if getattr(value, "ndim", None) == 0 and hasattr(value, "item"):
        value = value.item()
    if isinstance(value, (str, bytes, bytearray)):
        unit = "characters" if isinstance(value, str) else "bytes"
        text = repr(value[:limit] if isinstance(value, str) else bytes(value[:limit]))
        if len(value) <= limit and len(text) <= limit + 3:
            return text
        return f"{text[:limit + 1]}… ({len(value)} {unit})"
    text = _REPR.repr(value)
    return text if len(text) <= limit else f"{text[:limit]}…"


#: Characters of a whole message (that may embed outside text) kept in a log line.
MESSAGE_LIMIT: Final = 500
#: Characters of a library's own complaint (a parser's message) kept inside an error.
LIBRARY_MESSAGE: Final = 200


def clip(message: object, limit: int = MESSAGE_LIMIT) -> str:
    """``str(message)`` itself if at most ``limit`` characters, else its start and its length:
    for messages built elsewhere that may embed outside text (an error of another layer, a
    library's exception)."""
    text = str(message)
    return text if len(text) <= limit else f"{text[:limit]}… ({len(text)} characters)"
