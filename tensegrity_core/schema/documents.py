"""Text and files to plain data: YAML, JSON or TOML, each bounded by :class:`Limits`.

:func:`parse_text` reads text that a caller already has (a service request, a string in a
program); :func:`read_file` reads a file (size checked before reading, UTF-8 checked, the
format from the suffix); :func:`read_text` reads a file's text the same way for a table
format parsed elsewhere (CSV). None ever treats text as a file name or a file name as
text: which one a caller has is the caller's to say (or
:func:`~tensegrity_core.schema.sources.resolve_source`'s, for local use).

YAML keeps lines (:mod:`~tensegrity_core.schema.yaml_reader`). JSON is read by Python's
``json`` module (C, about 50x faster than YAML on large generated files) with a nesting
check before parsing and duplicate keys refused; TOML by ``tomllib``. Neither records
lines; :func:`parse_text` with ``fmt="yaml"`` reads JSON text too, with lines, when an
error must be located.
"""

from __future__ import annotations

import json
import os
import re
import stat
import tomllib
from pathlib import Path
from typing import Any, Final

import numpy as np

from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import LIBRARY_MESSAGE
from tensegrity_core.schema.errors import SchemaError, clip, excerpt
from tensegrity_core.schema.limits import DEFAULT_LIMITS, Limits
from tensegrity_core.schema.yaml_reader import parse_yaml

FORMATS: Final = ("yaml", "json", "toml")
SUFFIXES: Final = {".yaml": "yaml", ".yml": "yaml", ".json": "json", ".toml": "toml"}
_JSON_STRING: Final = re.compile(rb'"(?:[^"\\]|\\.)*"', re.S)
#: A first line that only TOML starts with: a table header (no comma or nested bracket, unlike
#: a flow list such as ``[1, 2]``) or a ``key = value`` assignment.
_TOML_FIRST_LINE: Final = re.compile(r'^(\[\[?[^\[\],]+\]\]?\s*(#.*)?$|[A-Za-z0-9_"\'.-]+\s*=)')
_TOML_WHERE: Final = re.compile(r"\(at line ([0-9]+), column [0-9]+\)|\(at end of document\)")


def check_size(text: str, limits: Limits, error: type[SchemaError] = SchemaError, file: str | None = None,
               what: str = "the text") -> None:
    """Refuse ``text`` longer than ``limits.max_bytes`` (UTF-8 bytes), before any parsing."""
    if len(text) <= limits.max_bytes // 4:
        return
    size = len(text) if len(text) > limits.max_bytes else len(text.encode("utf-8", "surrogatepass"))
    if size > limits.max_bytes:
        raise error(f"{what} is {size} bytes, more than the limit of {limits.max_bytes}", file=file)


def guess_format(text: str) -> str:
    """``"toml"`` for text whose first line is a TOML table header (``[name]``, ``[[name]]``)
    or assignment (``key = value``), ``"json"`` for other text that starts with ``{`` or ``[``
    (a JSON or YAML flow collection: :func:`parse_text` reads it as YAML when it is not JSON),
    else ``"yaml"``. A one-item list of a bare key (``[a]``) is a TOML table header."""
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if _TOML_FIRST_LINE.match(s):
            return "toml"
        return "json" if s.startswith(("{", "[")) else "yaml"
    return "yaml"


def parse_text(text: object, fmt: str | None = None, *, limits: Limits = DEFAULT_LIMITS,
               error: type[SchemaError] = SchemaError, file: str | None = None) -> Any:
    """Parse ``text`` as ``fmt`` (``"yaml"``, ``"json"``, ``"toml"``; ``None`` guesses with
    :func:`guess_format`, and JSON-looking text that is not JSON is read as YAML)."""
    return parse_text_format(text, fmt, limits=limits, error=error, file=file)[0]


def parse_text_format(text: object, fmt: str | None = None, *, limits: Limits = DEFAULT_LIMITS,
                      error: type[SchemaError] = SchemaError, file: str | None = None) -> tuple[Any, str]:
    """``(data, format read)`` of ``text``, as :func:`parse_text` (anything but a string is refused)."""
    if not isinstance(text, str):
        raise error(f"a description must be text, got {type(text).__name__}", file=file)
    check_size(text, limits, error, file)
    if fmt is None:
        fmt = guess_format(text)
        if fmt == "json":
            try:
                return _parse_json(text, limits, error, file), "json"
            except SchemaError:
                fmt = "yaml"
    if fmt == "yaml":
        return parse_yaml(text, limits=limits, error=error, file=file), fmt
    if fmt == "json":
        return _parse_json(text, limits, error, file), fmt
    if fmt == "toml":
        return _parse_toml(text, error, file), fmt
    raise error(f"unknown format {excerpt(fmt)}; formats: {', '.join(FORMATS)}", file=file)


def read_file(path: str | os.PathLike[str], *, limits: Limits = DEFAULT_LIMITS,
              error: type[SchemaError] = SchemaError, fmt: str | None = None,
              what: str = "file") -> tuple[Any, str, str]:
    """``(data, text, fmt)`` of the description file ``path``: a regular file of at most
    ``limits.max_bytes`` bytes of UTF-8 text, its format from the suffix (``.yaml``,
    ``.yml``, ``.json``, ``.toml``) unless ``fmt`` is given. Errors name the file (as
    ``what``: "scene file", ...)."""
    path = Path(path)
    fmt = fmt or SUFFIXES.get(path.suffix.lower())
    if fmt is None:
        raise error(f"cannot tell the format of {excerpt(str(path))}: use a file ending in "
                    f"{', '.join(SUFFIXES)}")
    text = read_text(path, limits=limits, error=error, what=what)
    return parse_text(text, fmt, limits=limits, error=error, file=path.name), text, fmt


def read_text(path: str | os.PathLike[str], *, limits: Limits = DEFAULT_LIMITS,
              error: type[SchemaError] = SchemaError, what: str = "file") -> str:
    """The text of the regular file ``path``: at most ``limits.max_bytes`` bytes of UTF-8, as
    :func:`read_file` reads, for the tables this layer does not parse itself (CSV)."""
    path = Path(path)
    return decode_utf8(read_bytes(path, limits, error, what), error, path.name)


def read_bytes(path: Path, limits: Limits, error: type[SchemaError], what: str = "file") -> bytes:
    """The bytes of the regular file ``path`` (at most ``limits.max_bytes``, checked before
    and while reading: ``/proc`` files report a size of 0)."""
    shown = excerpt(str(path))
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise error(f"{what} not found: {shown}") from None
    except OSError as err:
        raise error(f"cannot read {shown}: {err.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{shown} is not a regular file")
    if info.st_size > limits.max_bytes:
        raise error(f"{shown} is {info.st_size} bytes, more than the limit of {limits.max_bytes}")
    try:
        with open(path, "rb") as fh:
            data = fh.read(limits.max_bytes + 1)
    except OSError as err:
        raise error(f"cannot read {shown}: {err.strerror}") from None
    if len(data) > limits.max_bytes:
        raise error(f"{shown} is more than {limits.max_bytes} bytes, the limit")
    return data


def decode_utf8(data: bytes, error: type[SchemaError], file: str | None) -> str:
    """``data`` as UTF-8 text; a byte that is not UTF-8 is named with its line."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise error(f"not UTF-8 text: byte 0x{data[err.start]:02x} at offset {err.start}", line=line,
                    file=file) from None


def _parse_json(text: str, limits: Limits, error: type[SchemaError], file: str | None) -> Any:
    raw = text.encode("utf-8", "surrogatepass")
    depth = _json_depth(raw)
    if depth > limits.max_depth:
        raise error(f"nested deeper than {limits.max_depth} levels", file=file)
    try:
        return json.loads(text, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as err:
        raise error(f"invalid JSON: {err.msg}", line=err.lineno, file=file) from None
    except _DuplicateKey as err:
        raise error(f"duplicate key {excerpt(err.key)}", file=file) from None
    except (ValueError, RecursionError) as err:       # e.g. an integer of more than 4300 digits
        raise error(f"invalid JSON: {clip(err, LIBRARY_MESSAGE)}", file=file) from None


def _json_depth(raw: bytes) -> int:
    """Deepest nesting of ``[`` and ``{`` in JSON text, without parsing: brackets inside
    strings are skipped (a bracket is inside a string when an odd number of unescaped
    quotes precede it)."""
    if b"\\" in raw:                                  # escaped quotes: drop strings the slow way
        raw = _JSON_STRING.sub(b'""', raw)
    codes = np.frombuffer(raw, dtype=np.uint8)
    where = np.flatnonzero(_BRACKET_STEP[codes])
    if not where.size:
        return 0
    quotes = np.flatnonzero(codes == ord('"'))
    outside = np.searchsorted(quotes, where) % 2 == 0
    steps = _BRACKET_STEP[codes[where[outside]]].astype(np.int32)
    return int(np.cumsum(steps).max(initial=0))


_BRACKET_STEP: Final = np.zeros(256, dtype=np.int8)
_BRACKET_STEP[[ord("["), ord("{")]] = 1
_BRACKET_STEP[[ord("]"), ord("}")]] = -1


class _DuplicateKey(TensegrityError):
    def __init__(self, key: str) -> None:
        super().__init__(key)
        self.key = key


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise _DuplicateKey(key)
            seen.add(key)
    return out


def _parse_toml(text: str, error: type[SchemaError], file: str | None) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        where = _TOML_WHERE.search(str(err))
        line = None
        if where:
            line = int(where.group(1)) if where.group(1) else text.count("\n") + 1
        reason = _TOML_WHERE.sub("", str(err)).strip()
        raise error(f"invalid TOML: {clip(reason, LIBRARY_MESSAGE)}", line=line, file=file) from None
    except RecursionError:
        raise error("invalid TOML: nested too deeply", file=file) from None
