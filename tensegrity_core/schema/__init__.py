"""The schema and file layer shared by every description format (scenes, structures, sweeps, ...).

- :class:`SchemaError`: the one error base class of every format; it carries ``key`` (key
  path), ``line`` and ``file`` and formats them once. Each format subclasses it
  (``SceneError``, ``StructureError``, ``SweepError``, ``TrajectoryFileError``, ...).
- :func:`parse_text` / :func:`read_file`: YAML, JSON or TOML text or files to plain data,
  bounded by :class:`Limits` (size, nesting depth, aliases) before and while parsing;
  :func:`read_text`: a file's bounded text for table formats (CSV). YAML results are
  :class:`LocatedDict`/:class:`LocatedList` that know their lines (:func:`line_of`;
  :func:`plain` drops them).
- :class:`Reader`: key-path checks (mappings, lists, allowed and required keys with "did you
  mean" suggestions and aliases, numbers with bounds, vectors, strings, choices, integers,
  booleans, checks kept as functions); every format's schema is a subclass.
  :func:`number_rows`, :func:`plain_numbers`, :func:`within_bounds`: whole columns at once.
- Key paths (``effects[2].fold_limit.restitution``): :func:`parse_key_path`,
  :func:`format_key_path`, :func:`get_at`, :func:`exists`, :func:`with_value_at` (a copy),
  :func:`set_in_place` (the document itself); patterns that select entries by name and
  :func:`resolve` (sweeps).
- :func:`resolve_source`: what a "name, path, text or dict" argument is, for every loader.
- :func:`excerpt`, :func:`suggest`: bounded quotes of values and suggestions for messages.
- :class:`ShippedFiles`: description files shipped as package data, by name.

Each format keeps only its own schema: ``tensegrity_core.sim.scene`` (scenes),
``tensegrity_core.general.structure_schema`` (structures), ``tensegrity_core.sweep.spec``
(sweeps), ``tensegrity_ros.trajectory_file`` (actuator trajectories). No module outside this
package parses a user's file itself (``tests/test_layers.py`` checks it).
"""

from tensegrity_core.schema.columns import number_rows, plain_numbers, within_bounds
from tensegrity_core.schema.documents import (
    check_size,
    guess_format,
    parse_text,
    parse_text_format,
    read_file,
    read_text,
)
from tensegrity_core.schema.errors import (
    KeyPath,
    SchemaError,
    clip,
    described,
    excerpt,
    format_key_path,
    suggest,
    type_name,
)
from tensegrity_core.schema.keypath import (
    KeyPathError,
    exists,
    get_at,
    parse_key_path,
    parse_pattern,
    resolve,
    set_in_place,
    with_value_at,
)
from tensegrity_core.schema.limits import DEFAULT_LIMITS, Limits
from tensegrity_core.schema.located import LocatedDict, LocatedList, line_of, plain
from tensegrity_core.schema.reader import MAX_MAGNITUDE, Reader, is_number, number_reason
from tensegrity_core.schema.shipped import ShippedFiles
from tensegrity_core.schema.sources import Source, resolve_source
from tensegrity_core.schema.yaml_reader import parse_yaml

__all__ = [
    "DEFAULT_LIMITS", "KeyPath", "KeyPathError", "Limits", "LocatedDict", "LocatedList", "MAX_MAGNITUDE", "Reader",
    "SchemaError", "ShippedFiles", "Source",
    "check_size", "clip", "described", "excerpt", "exists", "format_key_path", "get_at", "guess_format", "is_number", "line_of",
    "number_reason", "number_rows", "parse_key_path", "parse_pattern", "parse_text", "parse_text_format",
    "parse_yaml", "plain", "plain_numbers", "read_file", "read_text", "resolve", "resolve_source", "set_in_place",
    "suggest", "type_name", "with_value_at", "within_bounds",
]
