"""The schema and file layer shared by every description format (scenes, structures, ...).

- :class:`SchemaError`: the one error base class; it carries ``key`` (key path), ``line``
  and ``file``. Each format subclasses it (``SceneError``, ``StructureError``).
- :func:`parse_text` / :func:`read_file`: YAML, JSON or TOML text or files to plain data,
  bounded by :class:`Limits` (size, nesting depth, aliases) before and while parsing.
  YAML results are :class:`LocatedDict`/:class:`LocatedList` that know their lines
  (:func:`line_of`).
- :class:`Reader`: key-path checks (mappings, allowed and required keys with "did you
  mean" suggestions, numbers with bounds, vectors, strings, choices, integers).
- :func:`parse_key_path`, :func:`format_key_path`, :func:`get_at`, :func:`set_at`: key
  paths such as ``effects[2].fold_limit.restitution`` in parsed descriptions.
- :func:`excerpt`, :func:`suggest`: bounded quotes of values and suggestions for messages.
- :class:`ShippedFiles`: description files shipped as package data, by name.

Each format keeps only its own schema: ``tensegrity_core.sim.scene`` (scenes),
``tensegrity_core.general.structure_schema`` (structures).
"""

from tensegrity_core.schema.documents import check_size, guess_format, parse_text, parse_text_format, read_file
from tensegrity_core.schema.errors import KeyPath, SchemaError, clip, excerpt, format_key_path, suggest, type_name
from tensegrity_core.schema.keypath import get_at, parse_key_path, set_at
from tensegrity_core.schema.limits import DEFAULT_LIMITS, Limits
from tensegrity_core.schema.located import LocatedDict, LocatedList, line_of
from tensegrity_core.schema.reader import MAX_MAGNITUDE, Reader, is_number, number_reason
from tensegrity_core.schema.shipped import ShippedFiles
from tensegrity_core.schema.yaml_reader import parse_yaml

__all__ = [
    "DEFAULT_LIMITS", "KeyPath", "Limits", "LocatedDict", "LocatedList", "MAX_MAGNITUDE", "Reader", "SchemaError", "ShippedFiles",
    "check_size", "clip", "excerpt", "format_key_path", "get_at", "guess_format", "is_number", "line_of",
    "number_reason", "parse_key_path", "parse_text", "parse_text_format", "parse_yaml", "read_file", "set_at",
    "suggest", "type_name",
]
