"""The members of a structure description, in either form, read at numpy's speed.

Members come as a list with one entry per member (``{name, nodes: [a, b], type, EA, ...}``
or a pair ``[a, b]``), or in the *array form* of generated structures: a mapping of columns
(``nodes: [[0, 1], [1, 2], ...]`` node positions, ``EA: 1.0e6`` or one value per member,
...). Neither is read with a Python-level check per value where numpy can check a whole
column: the per-member form in one lean pass (entries of an unusual shape, and any entry
that fails a check, are read again by the careful reader :meth:`MemberReader.member_entry`,
which words the error), the array form column by column
(:mod:`~tensegrity_core.schema.columns`). Errors are
:class:`~tensegrity_core.general.structure.StructureError` naming the member in words and
its line; the rest of the description is :mod:`~tensegrity_core.general.structure_schema`'s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Final, TypeAlias, cast

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.structure import KIND_ALIASES, StructureError
from tensegrity_core.schema import (
    MAX_MAGNITUDE,
    KeyPath,
    Reader,
    excerpt,
    number_reason,
    plain_numbers,
    suggest,
    type_name,
    within_bounds,
)
from tensegrity_core.schema.columns import NUMBER_TYPES

MEMBER_KEYS: Final = ("A", "E", "EA", "mass", "name", "nodes", "rest_length", "rest_length_ratio", "type")
MEMBER_ALIASES: Final = {"ends": "nodes", "kind": "type", "l0": "rest_length", "l0_ratio": "rest_length_ratio"}
#: The unit of each number a member (or ``defaults``) takes (``""``: dimensionless).
MEMBER_UNITS: Final = {"A": "m^2", "E": "Pa", "EA": "N", "mass": "kg", "rest_length": "m", "rest_length_ratio": ""}
_KIND_NAMES: Final = "bar, strut, string, cable, actuator"
_ABSENT: Final = object()

#: Allowed key -> the key as written in the description.
Keys: TypeAlias = Mapping[str, Any]
#: The members read from either form: ``(names, node pairs (m, 2), kinds, EA [N],
#: rest lengths [m], masses [kg])``.
MemberColumns: TypeAlias = tuple[list[str], NDArray[np.int64], list[str], NDArray[np.float64],
                                 NDArray[np.float64], NDArray[np.float64]]
#: One member read by the careful reader: ``(name, (a, b), kind, EA, rest length or nan,
#: rest-length ratio, mass)``.
MemberEntry: TypeAlias = tuple[str, tuple[int, int], str, float, float, float, float]


def member_count(raw: object) -> int:
    """How many members ``members`` lists (0 if it is neither form), without reading them."""
    if isinstance(raw, dict):
        ends = raw.get("nodes", raw.get("ends"))
        return len(ends) if isinstance(ends, list) else 0
    return len(raw) if isinstance(raw, list) else 0


def default_stiffness(defaults: Mapping[str, Any]) -> float | None:
    """EA [N] of the checked defaults (numbers), or None."""
    if "EA" in defaults:
        return float(defaults["EA"])
    if "E" in defaults and "A" in defaults:
        return float(defaults["E"] * defaults["A"])
    return None


class MemberReader(Reader):
    """The members' part of the structure schema (and the node references and member types
    the rest of it shares)."""

    def __init__(self, file: str | None = None) -> None:
        super().__init__(StructureError, file)

    def number_at(self, value: object, what: str, path: KeyPath, container: Any = None, key: Any = None, *,
                  unit: str, positive: bool = False, nonneg: bool = False) -> float:
        """``value`` as a number in ``unit`` (``positive``: > 0, ``nonneg``: >= 0); ``what`` in words."""
        return self.value_number(value, path, container, key, unit=unit, entry=what,
                                 lo=0.0 if positive or nonneg else None, lo_open=positive)

    def node_ref(self, ref: object, names: Mapping[str, int], what: str, path: KeyPath, container: Any,
                 key: Any) -> int:
        """The index of the node named ``ref`` (a name, or an integer naming a node "0", "1", ...)."""
        if isinstance(ref, bool) or not isinstance(ref, (str, int)):
            raise self.error(f"{what}: a node reference must be a node name, got {excerpt(ref)}", path, container,
                             key)
        name = str(ref)
        if name not in names:
            raise self.error(f"{what}: unknown node {excerpt(name)}{suggest(name, names)}", path, container, key)
        return names[name]

    def kind(self, kind: object, what: str, path: KeyPath, container: Any, key: Any) -> str:
        """The canonical member type of ``kind`` (``strut`` -> ``bar``, ...)."""
        canon = KIND_ALIASES.get(kind.lower()) if isinstance(kind, str) else None
        if canon is None:
            raise self.error(f"{what}: unknown type {excerpt(kind)}; use one of {_KIND_NAMES}"
                             f"{suggest(str(kind).lower(), KIND_ALIASES)}", path, container, key)
        return canon

    def members(self, raw: object, path: KeyPath, parent: Any, key: Any, index: dict[str, int],
                defaults: Mapping[str, Any], coords: NDArray[np.float64]) -> MemberColumns:
        """``members`` in either form: ``(names, pairs (m, 2), kinds, EA, rest lengths, masses)``."""
        if isinstance(raw, dict):
            return self.member_columns(raw, path, len(index), defaults, coords)
        if not isinstance(raw, list) or not raw:
            raise self.error("members must be a non-empty list", path, parent, key)
        return self.member_list(raw, path, index, defaults, coords)

    # -- the per-member form ---------------------------------------------------------------------
    def member_list(self, raw: list[Any], path: KeyPath, index: dict[str, int], defaults: Mapping[str, Any],
                    coords: NDArray[np.float64]) -> MemberColumns:
        """The per-member form in one pass. Entries of the common shapes (a pair ``[a, b]``, or
        a mapping of canonical keys with values of the right types) are read inline; every
        other entry (aliases, E and A, anything wrong) by :meth:`member_entry`, which words
        errors. Numeric bounds are checked afterwards on whole columns."""
        m = len(raw)
        names: list[str] = [""] * m               # every entry is set below
        ends = np.empty((m, 2), dtype=np.int64)
        kinds: list[str] = [""] * m
        EA, mass = np.empty(m), np.empty(m)
        l0 = np.full(m, np.nan)                   # nan: from the ratio and the drawn length
        ratio = np.ones(m)
        kind_of = dict(KIND_ALIASES)
        default_type = defaults.get("type", "string")
        default_kind = kind_of.get(default_type.lower()) if isinstance(default_type, str) else None
        default_EA = default_stiffness(defaults)
        default_ratio = defaults.get("rest_length_ratio", 1.0)
        default_mass = defaults.get("mass", 0.0)
        inline_keys = set(MEMBER_KEYS) - {"E", "A"}
        numbers = NUMBER_TYPES

        def node(ref: object) -> int | None:
            i = index.get(ref) if type(ref) is str else None
            return index.get(str(ref)) if i is None and type(ref) is int else i

        # the values as written (checked below, or by member_entry)
        pair: Any
        item_kind: str | None
        stiffness: Any
        length: Any
        r: Any
        w: Any
        name: Any
        for i, item in enumerate(raw):
            if not isinstance(item, list) and not (isinstance(item, dict) and item.keys() <= inline_keys):
                names[i], ends[i], kinds[i], EA[i], l0[i], ratio[i], mass[i] = self.member_entry(
                    i, item, raw, path, index, defaults)
                continue
            if isinstance(item, list):
                pair, item_kind, stiffness, length, r, w, name = item, default_kind, default_EA, None, \
                    default_ratio, default_mass, f"m{i}"
            else:
                get = item.get
                pair = get("nodes")
                kind = get("type", _ABSENT)
                item_kind = default_kind if kind is _ABSENT else (kind_of.get(kind) if type(kind) is str else None)
                stiffness = get("EA", default_EA)
                length = get("rest_length", _ABSENT)
                r = get("rest_length_ratio", default_ratio)
                w = get("mass", default_mass)
                name = get("name", _ABSENT)
                name = f"m{i}" if name is _ABSENT else (name if type(name) is str else (str(name) if type(name) is int
                                                                                         else None))
                if length is _ABSENT:
                    length = None
                elif type(length) not in numbers or "rest_length_ratio" in item:
                    name = None                   # the careful reader words it
            a = b = None
            if isinstance(pair, list) and len(pair) == 2:
                a, b = node(pair[0]), node(pair[1])
            if (a is None or b is None or item_kind is None or name is None or type(stiffness) not in numbers
                    or type(r) not in numbers or type(w) not in numbers):
                names[i], ends[i], kinds[i], EA[i], l0[i], ratio[i], mass[i] = self.member_entry(
                    i, item, raw, path, index, defaults)
                continue
            names[i], kinds[i], EA[i], ratio[i], mass[i] = name, item_kind, stiffness, r, w
            ends[i] = a, b
            if length is not None:
                l0[i] = length
        bad = _first_bad_member(EA, l0, ratio, mass)
        if bad is not None:
            self.member_entry(bad, raw[bad], raw, path, index, defaults)       # raises, worded
        self.unique_names(names, raw, path)
        return names, ends, kinds, EA, _rest_lengths(l0, ratio, ends, coords), mass

    def unique_names(self, names: list[str], raw: Any, path: KeyPath) -> None:
        """Refuse a member name given twice."""
        if len(set(names)) == len(names):
            return
        first: dict[str, int] = {}
        for i, name in enumerate(names):
            if name in first:
                raise self.error(f"member {excerpt(name)}: name used twice (members[{first[name]}] and "
                                 f"members[{i}])", path + (i,), raw, i)
            first[name] = i

    def member_entry(self, i: int, item: object, raw: list[Any], path: KeyPath, index: Mapping[str, int],
                     defaults: Mapping[str, Any]) -> MemberEntry:
        """One member entry read with every check, in order (see :data:`MemberEntry`)."""
        where = path + (i,)
        if isinstance(item, (list, tuple)):
            item = {"nodes": item}
        if not isinstance(item, dict):
            raise self.error(f"members[{i}] must be a mapping like {{nodes: [a, b], type: string}} or a "
                             f"pair [a, b], got {excerpt(item)}", where, raw, i)
        mk = self.keys(item, where, MEMBER_KEYS, aliases=MEMBER_ALIASES, entry=f"members[{i}]")
        entry = item

        def val(k: str) -> Any:
            return entry[mk[k]] if k in mk else defaults.get(k)

        written = item[mk["name"]] if "name" in mk else f"m{i}"
        if isinstance(written, bool) or not isinstance(written, (str, int)):
            raise self.error(f"members[{i}]: name must be a string, got {excerpt(written)}", where, raw, i)
        name = str(written)
        what = f"member {excerpt(name)}"
        if "nodes" not in mk:
            raise self.error(f"{what}: missing 'nodes: [a, b]'", where, raw, i)
        ends = item[mk["nodes"]]
        if not isinstance(ends, (list, tuple)) or len(ends) != 2:
            raise self.error(f"{what}: nodes must be a pair [a, b], got {excerpt(ends)}", where, raw, i)
        a, b = (self.node_ref(e, index, what, where, raw, i) for e in ends)
        kind = self.kind(val("type") if val("type") is not None else "string", what, where, raw, i)
        EA = self.member_stiffness(item, mk, defaults, what, where, raw, i)
        if "rest_length" in mk and "rest_length_ratio" in mk:
            raise self.error(f"{what}: give rest_length or rest_length_ratio, not both", where, raw, i)
        l0, ratio = math.nan, 1.0
        if "rest_length" in mk:
            l0 = self.number_at(item[mk["rest_length"]], f"{what}: rest_length", where, raw, i, unit="m", positive=True)
        else:
            r = val("rest_length_ratio")
            ratio = 1.0 if r is None else self.number_at(r, f"{what}: rest_length_ratio", where, raw, i, unit="",
                                                         positive=True)
        w = val("mass")
        w = 0.0 if w is None else self.number_at(w, f"{what}: mass", where, raw, i, unit="kg", nonneg=True)
        return name, (a, b), kind, EA, l0, ratio, w

    def member_stiffness(self, item: Mapping[Any, Any], mk: Keys, defaults: Mapping[str, Any], what: str,
                         where: KeyPath, raw: list[Any], i: int) -> float:
        """EA [N] of one member: its EA, or its (or the defaults') E times A, or the defaults'."""
        if "EA" in mk and ("E" in mk or "A" in mk):
            raise self.error(f"{what}: give EA, or E and A, not both", where, raw, i)
        if "EA" in mk:
            return self.number_at(item[mk["EA"]], f"{what}: EA", where, raw, i, unit="N", positive=True)
        if "E" in mk or "A" in mk:
            E = item[mk["E"]] if "E" in mk else defaults.get("E")
            A = item[mk["A"]] if "A" in mk else defaults.get("A")
            if E is None or A is None:
                raise self.error(f"{what}: axial stiffness needs both E and A (or EA)", where, raw, i)
            product = (self.number_at(E, f"{what}: E", where, raw, i, unit="Pa", positive=True)
                       * self.number_at(A, f"{what}: A", where, raw, i, unit="m^2", positive=True))
            return self.number_at(product, f"{what}: EA = E A", where, raw, i, unit="N", positive=True)
        stiffness = default_stiffness(defaults)
        if stiffness is None:
            raise self.error(f"{what}: axial stiffness missing: give EA, or E and A, in the member or in defaults",
                             where, raw, i)
        return self.number_at(stiffness, f"{what}: EA = E A", where, raw, i, unit="N", positive=True)

    # -- the array form --------------------------------------------------------------------------
    def member_columns(self, raw: dict[Any, Any], path: KeyPath, n: int, defaults: Mapping[str, Any],
                       coords: NDArray[np.float64]) -> MemberColumns:
        """The array form: ``members`` is a mapping of columns, each a list with one value per
        member or (all but ``nodes`` and ``name``) one value for every member."""
        mk = self.keys(raw, path, MEMBER_KEYS, aliases=MEMBER_ALIASES, entry="members")
        if "nodes" not in mk:
            raise self.error("members: the array form needs 'nodes: [[a, b], ...]' (node positions, from 0)", path,
                             raw, None)
        ends_raw = raw[mk["nodes"]]
        if not isinstance(ends_raw, list) or not ends_raw:
            raise self.error("members.nodes must be a non-empty list of node position pairs [[a, b], ...]",
                             path + ("nodes",), raw, mk["nodes"])
        m = len(ends_raw)
        ends = self.index_pairs(ends_raw, path + ("nodes",), n)

        def col(key: str, default: float | None) -> NDArray[np.float64]:
            return self.column(raw, path, mk, key, m, default)

        if "name" in mk:
            written = raw[mk["name"]]
            if not isinstance(written, list) or len(written) != m:
                raise self.error(f"members.name must be a list of {m} names, got {type_name(written)} "
                                 f"({excerpt(written)})", path + ("name",), raw, mk["name"])
            for i, name in enumerate(written):
                if isinstance(name, bool) or not isinstance(name, (str, int)):
                    raise self.error(f"members.name[{i}] must be a string, got {excerpt(name)}",
                                     path + ("name", i), written, i)
            names = [str(x) for x in written]
            self.unique_names(names, ends_raw, path + ("nodes",))
        else:
            names = [f"m{i}" for i in range(m)]
        kinds = self.kind_column(raw, path, mk, m, defaults.get("type", "string"))
        if "EA" in mk and ("E" in mk or "A" in mk):
            raise self.error("members: give EA, or E and A, not both", path + ("EA",), raw, mk["EA"])
        if "EA" in mk or "E" in mk or "A" in mk:
            EA = col("EA", None) if "EA" in mk else col("E", defaults.get("E")) * col("A", defaults.get("A"))
        else:
            EA = col("EA", default_stiffness(defaults))
        bad = np.flatnonzero(~within_bounds(EA, each=True))
        if bad.size:
            i = int(bad[0])
            raise self.error(f"member {excerpt(names[i])}: EA = E A {number_reason(float(EA[i]), unit='N')[1]}",
                             path + ("nodes", i), ends_raw, i)
        if "rest_length" in mk and "rest_length_ratio" in mk:
            raise self.error("members: give rest_length or rest_length_ratio, not both", path + ("rest_length",),
                             raw, mk["rest_length"])
        if "rest_length" in mk:
            l0 = col("rest_length", None)
        else:
            l0 = _rest_lengths(np.full(m, np.nan), col("rest_length_ratio", defaults.get("rest_length_ratio", 1.0)),
                               ends, coords)
        mass = col("mass", defaults.get("mass", 0.0))
        return names, ends, kinds, EA, l0, mass

    def index_pairs(self, rows: list[Any], path: KeyPath, n: int) -> NDArray[np.int64]:
        """``members.nodes`` of the array form: pairs of node positions ``0 <= a, b < n``."""
        arr: NDArray[Any] | None
        try:
            arr = np.array(rows)
        except (ValueError, TypeError):
            arr = None
        if (arr is not None and arr.shape == (len(rows), 2) and arr.dtype.kind in "iu"
                and all(type(a) is int and type(b) is int for a, b in rows)
                and not ((arr < 0) | (arr >= n)).any()):
            return arr.astype(np.int64, copy=False)
        for i, row in enumerate(rows):           # an unusual row (numpy integers, tuples) or a bad one
            if (not isinstance(row, (list, tuple)) or len(row) != 2
                    or not all(isinstance(x, (int, np.integer)) and not isinstance(x, bool) and 0 <= x < n
                               for x in row)):
                raise self.error(f"members.nodes[{i}] must be a pair [a, b] of node positions 0 to {n - 1}, got "
                                 f"{excerpt(row)}", path + (i,), rows, i)
        return np.array(rows, dtype=np.int64)

    def column(self, raw: Mapping[Any, Any], path: KeyPath, mk: Keys, key: str, m: int,
               default: float | None) -> NDArray[np.float64]:
        """Column ``key`` (one number for all or a list of ``m``), checked as a whole; positive
        except ``mass`` (>= 0). ``default`` when absent (None: required)."""
        nonneg = key == "mass"
        if key not in mk:
            if default is None:
                raise self.error(f"members: missing {key!r} (in the members or in defaults)", path, raw, None)
            return np.full(m, float(default))
        value = raw[mk[key]]
        where = path + (key,)
        if isinstance(value, list):
            if len(value) != m:
                raise self.error(f"members.{key} must have one value per member ({m}), got {len(value)}", where, raw,
                                 mk[key])
            if plain_numbers(value):
                arr = np.array(value, dtype=float)
                if within_bounds(arr) and ((arr >= 0) if nonneg else (arr > 0)).all():
                    return arr
            return np.array([self.number_at(v, f"members.{key}[{i}]", where + (i,), value, i, unit=MEMBER_UNITS[key],
                                            positive=not nonneg, nonneg=nonneg) for i, v in enumerate(value)])
        return np.full(m, self.number_at(value, f"members.{key}", where, raw, mk[key], unit=MEMBER_UNITS[key],
                                         positive=not nonneg, nonneg=nonneg))

    def kind_column(self, raw: Mapping[Any, Any], path: KeyPath, mk: Keys, m: int, default: object) -> list[str]:
        """``members.type`` of the array form: one type for all or one per member."""
        value = raw[mk["type"]] if "type" in mk else default
        if not isinstance(value, list):
            return [self.kind(value, "members", path + ("type",), raw, mk.get("type"))] * m
        if len(value) != m:
            raise self.error(f"members.type must have one value per member ({m}), got {len(value)}", path + ("type",),
                             raw, mk["type"])
        canon = {k: KIND_ALIASES.get(k.lower()) for k in {v for v in value if type(v) is str}}
        out = [canon.get(k) if type(k) is str else None for k in value]
        if None in out:
            i = out.index(None)
            self.kind(value[i], f"members.type[{i}]", path + ("type", i), value, i)      # raises, worded
        return cast(list[str], out)                                  # no None left: refused above


def _first_bad_member(EA: NDArray[np.float64], l0: NDArray[np.float64], ratio: NDArray[np.float64],
                      mass: NDArray[np.float64]) -> int | None:
    """The first member whose EA, rest length, ratio or mass is out of bounds, or None."""
    def bad(x: NDArray[np.float64], positive: bool = True) -> NDArray[np.bool_]:
        return ~np.isfinite(x) | (np.abs(x) > MAX_MAGNITUDE) | ((x <= 0) if positive else (x < 0))

    flags = bad(EA) | (bad(l0) & ~np.isnan(l0)) | bad(ratio) | bad(mass, positive=False)
    hits = np.flatnonzero(flags)
    return int(hits[0]) if hits.size else None


def _rest_lengths(l0: NDArray[np.float64], ratio: NDArray[np.float64], ends: NDArray[np.int64],
                  coords: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rest lengths given, else the ratio times the drawn length (1 m for a zero length)."""
    length = np.linalg.norm(coords[ends[:, 1]] - coords[ends[:, 0]], axis=1)
    from_ratio = np.where(length > 0, ratio * length, 1.0)
    return np.where(np.isnan(l0), from_ratio, l0)
