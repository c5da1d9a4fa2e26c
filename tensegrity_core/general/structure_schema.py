"""The structure description's schema: parsed data (dict) to a :class:`Structure`.

The format is documented in ``docs/structures.md``. Members come in one of two forms:
a list with one entry per member (``{name, nodes: [a, b], type, EA, ...}`` or a pair
``[a, b]``), or the *array form* for generated structures: a mapping of columns
(``nodes: [[0, 1], [1, 2], ...]`` node positions, ``EA: 1.0e6`` or one value per member,
...). Both are read without a Python-level check per value where numpy can check a whole
column: the per-member form in one lean pass (entries of an unusual shape, and any entry
that fails a check, are read again by the careful reader that words the error), the array
form column by column. Errors are :class:`StructureError` naming the entry in words and,
for YAML, the line.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Set
from typing import Any, Final, Literal, TypeAlias, cast, overload

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.structure import (
    KIND_ALIASES,
    STANDARD_GRAVITY,
    RigidBody,
    Structure,
    StructureError,
)
from tensegrity_core.schema import (
    MAX_MAGNITUDE,
    KeyPath,
    excerpt,
    is_number,
    line_of,
    number_reason,
    suggest,
    type_name,
)

TOP_KEYS: Final = {"name", "units", "description", "defaults", "nodes", "node_names", "members", "pinned",
            "rigid_bodies", "loads", "masses", "gravity"}
TOP_ALIASES: Final = {"supports": "pinned", "bodies": "rigid_bodies", "point_masses": "masses"}
MEMBER_KEYS: Final = {"name", "nodes", "type", "EA", "E", "A", "rest_length", "rest_length_ratio", "mass"}
MEMBER_ALIASES: Final = {"ends": "nodes", "kind": "type", "l0": "rest_length", "l0_ratio": "rest_length_ratio"}
DEFAULT_KEYS: Final = {"EA", "E", "A", "type", "rest_length_ratio", "mass"}
DEFAULT_ALIASES: Final = {"kind": "type", "l0_ratio": "rest_length_ratio"}
BODY_KEYS: Final = {"name", "nodes", "mass", "fixed"}
_KIND_NAMES: Final = "bar, strut, string, cable, actuator"
_NUMBER_TYPES: Final = {int, float}
_ABSENT: Final = object()

#: Canonical key -> the key as written in the description.
Keys: TypeAlias = Mapping[str, Any]
#: The members read from either form: ``(names, node pairs (m, 2), kinds, EA [N],
#: rest lengths [m], masses [kg])``.
MemberColumns: TypeAlias = tuple[list[str], NDArray[np.int64], list[str], NDArray[np.float64],
                                 NDArray[np.float64], NDArray[np.float64]]


def _err(message: str, container: Any = None, key: Any = None, entry: KeyPath = ()) -> StructureError:
    return StructureError(message, entry=entry, line=line_of(container, key))


def _check_keys(d: Mapping[Any, Any], allowed: Set[str], aliases: Mapping[Any, str], what: str) -> dict[str, Any]:
    """Canonical key -> key as written; unknown keys named with a suggestion."""
    out: dict[str, Any] = {}
    for key in d:
        canon = aliases.get(key, key)
        if canon not in allowed:
            raise _err(f"{what}: unknown key {excerpt(key)}{suggest(key, sorted(allowed))}; allowed: "
                       f"{', '.join(sorted(allowed))}", d, key)
        if canon in out:
            raise _err(f"{what}: {excerpt(key)} repeats {canon!r}", d, key)
        out[canon] = key
    return out


def _number(value: object, what: str, container: Any = None, key: Any = None, *, positive: bool = False,
            nonneg: bool = False) -> float:
    x, reason = number_reason(value, lo=0.0 if positive or nonneg else None, lo_open=positive)
    if reason is not None:
        raise _err(f"{what} {reason}", container, key)
    return x


def _vector(value: object, what: str, container: Any = None, key: Any = None) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise _err(f"{what} must be a list of 3 numbers [x, y, z], got {type_name(value)} ({excerpt(value)})",
                   container, key)
    return [_number(v, what, container, key) for v in value]


def _mapping(value: object, what: str, container: Any, key: Any) -> dict[Any, Any]:
    if not isinstance(value, dict):
        raise _err(f"{what} must be a mapping, got {type_name(value)} ({excerpt(value)})", container, key)
    return value


def _node_ref(ref: object, names: Mapping[str, int], what: str, container: Any, key: Any) -> int:
    if isinstance(ref, bool) or not isinstance(ref, (str, int)):
        raise _err(f"{what}: a node reference must be a node name, got {excerpt(ref)}", container, key)
    name = str(ref)
    if name not in names:
        raise _err(f"{what}: unknown node {excerpt(name)}{suggest(name, names)}", container, key)
    return names[name]


def _kind(kind: object, what: str, container: Any, key: Any) -> str:
    canon = KIND_ALIASES.get(kind.lower()) if isinstance(kind, str) else None
    if canon is None:
        raise _err(f"{what}: unknown type {excerpt(kind)}; use one of {_KIND_NAMES}"
                   f"{suggest(str(kind).lower(), KIND_ALIASES)}", container, key)
    return canon


def structure_from_dict(data: object, *, default_name: str = "", max_members: int | None = None) -> Structure:
    """Validate a description dict (see ``docs/structures.md``) and build the structure.

    ``max_members``: refuse descriptions with more members, before reading them."""
    if not isinstance(data, dict):
        raise StructureError(f"a structure description must be a mapping, got {type_name(data)} "
                             f"({excerpt(data)})")
    keys = _check_keys(data, TOP_KEYS, TOP_ALIASES, "structure")
    d = data

    def get(k: str, default: Any = None) -> Any:
        return d.get(keys[k], default) if k in keys else default

    if max_members is not None and "members" in keys:
        count = _member_count(data[keys["members"]])
        if count > max_members:
            raise _err(f"the structure has {count} members, more than the limit of {max_members}", data,
                       keys["members"], entry=("members",))
    name = get("name", default_name)
    if not isinstance(name, str):
        raise _err(f"name must be a string, got {excerpt(name)}", data, keys.get("name"))
    units = get("units", "SI")
    if not isinstance(units, str) or units.strip().upper() != "SI":
        raise _err(f"units: only SI (m, N, kg, s) is supported, got {excerpt(units)}", data, keys.get("units"))
    if not isinstance(get("description", ""), str):
        raise _err("description must be a string", data, keys.get("description"))

    node_names, coords = _read_nodes(data, keys)
    index = {n: i for i, n in enumerate(node_names)}
    defaults = _read_defaults(data, keys)
    members = _read_members(data, keys, index, defaults, coords)
    pinned = _read_pinned(data, keys, index)
    bodies = _read_bodies(data, keys, index)
    loads = np.zeros((len(node_names), 3))
    raw_loads = _mapping(get("loads", {}), "loads", data, keys.get("loads"))
    for node, value in raw_loads.items():
        i = _node_ref(node, index, "loads", raw_loads, node)
        loads[i] = _vector(value, f"loads of node {excerpt(node)}", raw_loads, node)
    masses = np.zeros(len(node_names))
    raw_masses = _mapping(get("masses", {}), "masses", data, keys.get("masses"))
    for node, value in raw_masses.items():
        i = _node_ref(node, index, "masses", raw_masses, node)
        masses[i] = _number(value, f"point mass of node {excerpt(node)}", raw_masses, node, nonneg=True)
    gravity = _read_gravity(data, keys)
    member_names, pairs, kinds, EA, l0, mass = members
    try:
        return Structure(
            name=name, node_names=tuple(node_names), nodes=coords, member_names=tuple(member_names),
            members=pairs, member_kinds=tuple(kinds), EA=EA, rest_lengths=l0, member_masses=mass,
            pinned=pinned, bodies=tuple(bodies), loads=loads, node_masses=masses, gravity=gravity)
    except StructureError as err:
        raise _locate(err, data, keys, node_names) from None


def _member_count(raw: object) -> int:
    if isinstance(raw, dict):
        ends = raw.get("nodes", raw.get("ends"))
        return len(ends) if isinstance(ends, list) else 0
    return len(raw) if isinstance(raw, list) else 0


def _locate(err: StructureError, data: Mapping[Any, Any], keys: Keys, node_names: list[str]) -> StructureError:
    """A :class:`Structure` validation error with the line of the entry it names."""
    if err.line is not None or not err.key:
        return err
    head = err.key[0]
    if not isinstance(head, str) or head not in keys:
        return err
    container = data[keys[head]]
    key = err.key[1] if len(err.key) > 1 else None
    if err.key[0] == "members" and isinstance(container, dict):        # the array form
        container = container.get("nodes", container.get("ends"))
    if err.key[0] == "nodes" and isinstance(container, list) and key in node_names:
        key = node_names.index(key)                                      # nodes as a list
    return err.located(line=line_of(container, key))


# ------------------------------------------------------------------------------ nodes
def _read_nodes(data: Mapping[Any, Any], keys: Keys) -> tuple[list[str], NDArray[np.float64]]:
    if "nodes" not in keys:
        raise StructureError("the description has no 'nodes'")
    raw = data[keys["nodes"]]
    if isinstance(raw, dict):
        if "node_names" in keys:
            raise _err("node_names goes with nodes as a list of [x, y, z]; here nodes are named already",
                       data, keys["node_names"])
        names: list[str] = []
        for name in raw:
            if isinstance(name, bool) or not isinstance(name, (str, int)):
                raise _err(f"node name must be a string, got {excerpt(name)}", raw, name)
            names.append(str(name))
        rows: list[Any] = list(raw.values())
        labels: list[Any] = list(raw)
    elif isinstance(raw, list):
        names = _node_names(data, keys, len(raw))
        rows, labels = raw, list(range(len(raw)))
    else:
        raise _err("nodes must be a mapping name: [x, y, z] or a list of [x, y, z]", data, keys["nodes"])
    if not names:
        raise _err("nodes is empty", data, keys["nodes"])
    coords = _number_rows(rows, 3)
    if coords is None:            # an unusual row (numpy numbers, tuples) or a bad one, worded
        coords = np.array([_vector(row, f"coordinates of node {excerpt(label)}", raw, label)
                           for label, row in zip(labels, rows)])
    return names, coords


def _node_names(data: Mapping[Any, Any], keys: Keys, n: int) -> list[str]:
    """``node_names`` (with nodes as a list of coordinates), or "0", "1", ..."""
    if "node_names" not in keys:
        return [str(i) for i in range(n)]
    raw = data[keys["node_names"]]
    if not isinstance(raw, list) or len(raw) != n:
        raise _err(f"node_names must be a list of {n} names (one per node), got {type_name(raw)} "
                   f"({excerpt(raw)})", data, keys["node_names"])
    for i, name in enumerate(raw):
        if isinstance(name, bool) or not isinstance(name, (str, int)):
            raise _err(f"node_names[{i}] must be a string, got {excerpt(name)}", raw, i)
    return [str(name) for name in raw]


def _number_rows(rows: list[Any], width: int) -> NDArray[np.float64] | None:
    """``rows`` (a list of lists of ``width`` numbers) as an (n, width) array, or None if any
    row is not such a list of finite numbers of at most MAX_MAGNITUDE (numpy checks the
    whole column; the caller words the first bad row)."""
    try:
        arr = np.array(rows, dtype=float)
    except (ValueError, TypeError, OverflowError):
        return None
    if arr.shape != (len(rows), width) or not _plain_numbers(rows, nested=True):
        return None
    if not _within_bounds(arr):
        return None
    return arr


def _plain_numbers(values: list[Any], nested: bool = False) -> bool:
    """Every value is an int or float (numpy would also take booleans and numeric strings)."""
    try:
        if nested:
            return all(set(map(type, row)) <= _NUMBER_TYPES for row in values)
        return set(map(type, values)) <= _NUMBER_TYPES
    except TypeError:
        return False


@overload
def _within_bounds(arr: NDArray[np.float64], each: Literal[False] = False) -> bool: ...
@overload
def _within_bounds(arr: NDArray[np.float64], each: Literal[True]) -> NDArray[np.bool_]: ...
def _within_bounds(arr: NDArray[np.float64], each: bool = False) -> bool | NDArray[np.bool_]:
    """All (or, with ``each``, elementwise) finite and at most MAX_MAGNITUDE in magnitude."""
    ok = np.isfinite(arr) & (np.abs(arr) <= MAX_MAGNITUDE)
    return ok if each else bool(ok.all())


# ------------------------------------------------------------------------------ defaults
def _read_defaults(data: Mapping[Any, Any], keys: Keys) -> dict[str, Any]:
    raw = _mapping(data.get(keys["defaults"], {}) if "defaults" in keys else {}, "defaults", data,
                   keys.get("defaults"))
    _check_keys(raw, DEFAULT_KEYS, DEFAULT_ALIASES, "defaults")
    out: dict[str, Any] = {}
    for key, value in raw.items():
        canon = DEFAULT_ALIASES.get(key, key)
        if canon == "type":
            out[canon] = value
        else:
            out[canon] = _number(value, f"defaults: {key}", raw, key, positive=canon != "mass", nonneg=canon == "mass")
    return out


# ------------------------------------------------------------------------------ members
def _read_members(data: Mapping[Any, Any], keys: Keys, index: dict[str, int], defaults: Mapping[str, Any],
                  coords: NDArray[np.float64]) -> MemberColumns:
    """``(names, pairs (m, 2), kinds, EA, rest lengths, masses)`` of either member form."""
    if "members" not in keys:
        raise StructureError("the description has no 'members'")
    raw = data[keys["members"]]
    if isinstance(raw, dict):
        return _member_columns(raw, len(index), defaults, coords)
    if not isinstance(raw, list) or not raw:
        raise _err("members must be a non-empty list", data, keys["members"])
    return _member_list(raw, index, defaults, coords)


def _default_stiffness(defaults: Mapping[str, Any]) -> float | None:
    """EA [N] of the defaults (read by :func:`_read_defaults`: numbers), or None."""
    if "EA" in defaults:
        return float(defaults["EA"])
    if "E" in defaults and "A" in defaults:
        return float(defaults["E"] * defaults["A"])
    return None


def _member_list(raw: list[Any], index: dict[str, int], defaults: Mapping[str, Any],
                 coords: NDArray[np.float64]) -> MemberColumns:
    """The per-member form in one pass. Entries of the common shapes (a pair ``[a, b]``, or a
    mapping of canonical keys with values of the right types) are read inline; every other
    entry (aliases, E and A, anything wrong) by :func:`_member_entry`, which words errors.
    Numeric bounds are checked afterwards on whole columns."""
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
    default_EA = _default_stiffness(defaults)
    default_ratio = defaults.get("rest_length_ratio", 1.0)
    default_mass = defaults.get("mass", 0.0)
    inline_keys = MEMBER_KEYS - {"E", "A"}
    numbers = _NUMBER_TYPES

    def node(ref: object) -> int | None:
        i = index.get(ref) if type(ref) is str else None
        return index.get(str(ref)) if i is None and type(ref) is int else i

    # the values as written (checked below, or by _member_entry)
    pair: Any
    item_kind: str | None
    stiffness: Any
    length: Any
    r: Any
    w: Any
    name: Any
    for i, item in enumerate(raw):
        if not isinstance(item, list) and not (isinstance(item, dict) and item.keys() <= inline_keys):
            names[i], ends[i], kinds[i], EA[i], l0[i], ratio[i], mass[i] = _member_entry(
                i, item, raw, index, defaults)
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
            names[i], ends[i], kinds[i], EA[i], l0[i], ratio[i], mass[i] = _member_entry(
                i, item, raw, index, defaults)
            continue
        names[i], kinds[i], EA[i], ratio[i], mass[i] = name, item_kind, stiffness, r, w
        ends[i] = a, b
        if length is not None:
            l0[i] = length
    bad = _first_bad_member(EA, l0, ratio, mass)
    if bad is not None:
        _member_entry(bad, raw[bad], raw, index, defaults)       # raises, worded
    _check_unique_names(names, raw)
    return names, ends, kinds, EA, _rest_lengths(l0, ratio, ends, coords), mass


def _first_bad_member(EA: NDArray[np.float64], l0: NDArray[np.float64], ratio: NDArray[np.float64],
                      mass: NDArray[np.float64]) -> int | None:
    def bad(x: NDArray[np.float64], positive: bool = True) -> NDArray[np.bool_]:
        return ~np.isfinite(x) | (np.abs(x) > MAX_MAGNITUDE) | ((x <= 0) if positive else (x < 0))

    flags = bad(EA) | (bad(l0) & ~np.isnan(l0)) | bad(ratio) | bad(mass, positive=False)
    hits = np.flatnonzero(flags)
    return int(hits[0]) if hits.size else None


def _rest_lengths(l0: NDArray[np.float64], ratio: NDArray[np.float64], ends: NDArray[np.int64],
                  coords: NDArray[np.float64]) -> NDArray[np.float64]:
    length = np.linalg.norm(coords[ends[:, 1]] - coords[ends[:, 0]], axis=1)
    from_ratio = np.where(length > 0, ratio * length, 1.0)
    return np.where(np.isnan(l0), from_ratio, l0)


def _check_unique_names(names: list[str], raw: Any) -> None:
    if len(set(names)) == len(names):
        return
    first: dict[str, int] = {}
    for i, name in enumerate(names):
        if name in first:
            raise _err(f"member {excerpt(name)}: name used twice (members[{first[name]}] and members[{i}])", raw, i)
        first[name] = i


def _member_entry(i: int, item: object, raw: list[Any], index: Mapping[str, int], defaults: Mapping[str, Any]
                  ) -> tuple[str, tuple[int, int], str, float, float, float, float]:
    """One member entry read with every check, in order:
    ``(name, (a, b), kind, EA, rest length or nan, ratio, mass)``."""
    if isinstance(item, (list, tuple)):
        item = {"nodes": item}
    if not isinstance(item, dict):
        raise _err(f"members[{i}] must be a mapping like {{nodes: [a, b], type: string}} or a "
                   f"pair [a, b], got {excerpt(item)}", raw, i)
    mk = _check_keys(item, MEMBER_KEYS, MEMBER_ALIASES, f"members[{i}]")
    entry = item

    def val(k: str) -> Any:
        return entry[mk[k]] if k in mk else defaults.get(k)

    written = item[mk["name"]] if "name" in mk else f"m{i}"
    if isinstance(written, bool) or not isinstance(written, (str, int)):
        raise _err(f"members[{i}]: name must be a string, got {excerpt(written)}", raw, i)
    name = str(written)
    what = f"member {excerpt(name)}"
    if "nodes" not in mk:
        raise _err(f"{what}: missing 'nodes: [a, b]'", raw, i)
    ends = item[mk["nodes"]]
    if not isinstance(ends, (list, tuple)) or len(ends) != 2:
        raise _err(f"{what}: nodes must be a pair [a, b], got {excerpt(ends)}", raw, i)
    a, b = (_node_ref(e, index, what, raw, i) for e in ends)
    kind = _kind(val("type") if val("type") is not None else "string", what, raw, i)
    EA = _member_stiffness(item, mk, defaults, what, raw, i)
    if "rest_length" in mk and "rest_length_ratio" in mk:
        raise _err(f"{what}: give rest_length or rest_length_ratio, not both", raw, i)
    l0, ratio = math.nan, 1.0
    if "rest_length" in mk:
        l0 = _number(item[mk["rest_length"]], f"{what}: rest_length", raw, i, positive=True)
    else:
        r = val("rest_length_ratio")
        ratio = 1.0 if r is None else _number(r, f"{what}: rest_length_ratio", raw, i, positive=True)
    w = val("mass")
    w = 0.0 if w is None else _number(w, f"{what}: mass", raw, i, nonneg=True)
    return name, (a, b), kind, EA, l0, ratio, w


def _member_stiffness(item: Mapping[Any, Any], mk: Keys, defaults: Mapping[str, Any], what: str, raw: list[Any],
                      i: int) -> float:
    def has(k: str) -> bool:
        return k in mk

    if has("EA") and (has("E") or has("A")):
        raise _err(f"{what}: give EA, or E and A, not both", raw, i)
    if has("EA"):
        return _number(item[mk["EA"]], f"{what}: EA", raw, i, positive=True)
    if has("E") or has("A"):
        E = item[mk["E"]] if has("E") else defaults.get("E")
        A = item[mk["A"]] if has("A") else defaults.get("A")
        if E is None or A is None:
            raise _err(f"{what}: axial stiffness needs both E and A (or EA)", raw, i)
        return _number(_number(E, f"{what}: E", raw, i, positive=True) * _number(A, f"{what}: A", raw, i,
                                                                              positive=True),
                       f"{what}: EA = E A", raw, i, positive=True)
    stiffness = _default_stiffness(defaults)
    if stiffness is None:
        raise _err(f"{what}: axial stiffness missing: give EA, or E and A, in the member or in defaults", raw, i)
    return _number(stiffness, f"{what}: EA = E A", raw, i, positive=True)


# ------------------------------------------------------------------------------ array form
def _member_columns(raw: dict[Any, Any], n: int, defaults: Mapping[str, Any],
                    coords: NDArray[np.float64]) -> MemberColumns:
    """The array form: ``members`` is a mapping of columns, each a list with one value per
    member or (all but ``nodes`` and ``name``) one value for every member."""
    mk = _check_keys(raw, MEMBER_KEYS, MEMBER_ALIASES, "members")
    if "nodes" not in mk:
        raise _err("members: the array form needs 'nodes: [[a, b], ...]' (node positions, from 0)", raw, None)
    ends_raw = raw[mk["nodes"]]
    if not isinstance(ends_raw, list) or not ends_raw:
        raise _err("members.nodes must be a non-empty list of node position pairs [[a, b], ...]", raw, mk["nodes"])
    m = len(ends_raw)
    ends = _index_pairs(ends_raw, n)

    def col(key: str, default: float | None) -> NDArray[np.float64]:
        return _column(raw, mk, key, m, default)

    if "name" in mk:
        written = raw[mk["name"]]
        if not isinstance(written, list) or len(written) != m:
            raise _err(f"members.name must be a list of {m} names, got {type_name(written)} ({excerpt(written)})",
                       raw, mk["name"])
        for i, name in enumerate(written):
            if isinstance(name, bool) or not isinstance(name, (str, int)):
                raise _err(f"members.name[{i}] must be a string, got {excerpt(name)}", written, i)
        names = [str(x) for x in written]
        _check_unique_names(names, ends_raw)
    else:
        names = [f"m{i}" for i in range(m)]
    kinds = _kind_column(raw, mk, m, defaults.get("type", "string"))
    if "EA" in mk and ("E" in mk or "A" in mk):
        raise _err("members: give EA, or E and A, not both", raw, mk["EA"])
    if "EA" in mk or "E" in mk or "A" in mk:
        EA = col("EA", None) if "EA" in mk else col("E", defaults.get("E")) * col("A", defaults.get("A"))
    else:
        EA = col("EA", _default_stiffness(defaults))
    bad = np.flatnonzero(~_within_bounds(EA, each=True))
    if bad.size:
        i = int(bad[0])
        raise _err(f"member {excerpt(names[i])}: EA = E A {number_reason(float(EA[i]))[1]}", ends_raw, i)
    if "rest_length" in mk and "rest_length_ratio" in mk:
        raise _err("members: give rest_length or rest_length_ratio, not both", raw, mk["rest_length"])
    if "rest_length" in mk:
        l0 = col("rest_length", None)
    else:
        l0 = _rest_lengths(np.full(m, np.nan), col("rest_length_ratio", defaults.get("rest_length_ratio", 1.0)),
                           ends, coords)
    mass = col("mass", defaults.get("mass", 0.0))
    return names, ends, kinds, EA, l0, mass


def _index_pairs(rows: list[Any], n: int) -> NDArray[np.int64]:
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
            raise _err(f"members.nodes[{i}] must be a pair [a, b] of node positions 0 to {n - 1}, got "
                       f"{excerpt(row)}", rows, i)
    return np.array(rows, dtype=np.int64)


def _column(raw: Mapping[Any, Any], mk: Keys, key: str, m: int, default: float | None) -> NDArray[np.float64]:
    """Column ``key`` (one number for all or a list of ``m``), checked as a whole; positive
    except ``mass`` (>= 0). ``default`` when absent (None: required)."""
    nonneg = key == "mass"
    if key not in mk:
        if default is None:
            raise _err(f"members: missing {key!r} (in the members or in defaults)", raw, None)
        return np.full(m, float(default))
    value = raw[mk[key]]
    if isinstance(value, list):
        if len(value) != m:
            raise _err(f"members.{key} must have one value per member ({m}), got {len(value)}", raw, mk[key])
        if _plain_numbers(value):
            arr = np.array(value, dtype=float)
            if _within_bounds(arr) and ((arr >= 0) if nonneg else (arr > 0)).all():
                return arr
        return np.array([_number(v, f"members.{key}[{i}]", value, i, positive=not nonneg, nonneg=nonneg)
                         for i, v in enumerate(value)])
    return np.full(m, _number(value, f"members.{key}", raw, mk[key], positive=not nonneg, nonneg=nonneg))


def _kind_column(raw: Mapping[Any, Any], mk: Keys, m: int, default: object) -> list[str]:
    value = raw[mk["type"]] if "type" in mk else default
    if not isinstance(value, list):
        return [_kind(value, "members", raw, mk.get("type"))] * m
    if len(value) != m:
        raise _err(f"members.type must have one value per member ({m}), got {len(value)}", raw, mk["type"])
    canon = {k: KIND_ALIASES.get(k.lower()) for k in {v for v in value if type(v) is str}}
    out = [canon.get(k) if type(k) is str else None for k in value]
    if None in out:
        i = out.index(None)
        _kind(value[i], f"members.type[{i}]", value, i)          # raises, worded
    return cast(list[str], out)                                  # no None left: refused above


# ------------------------------------------------------------------------------ supports, bodies, gravity
def _read_pinned(data: Mapping[Any, Any], keys: Keys, index: Mapping[str, int]) -> NDArray[np.bool_]:
    pinned = np.zeros((len(index), 3), dtype=bool)
    if "pinned" not in keys:
        return pinned
    raw = data[keys["pinned"]]
    raw_items: list[tuple[Any, Any]]
    if isinstance(raw, list):
        raw_items = [(node, "xyz") for node in raw]
    elif isinstance(raw, dict):
        raw_items = list(raw.items())
    else:
        raise _err("pinned must map node: axes (e.g. {b1: xyz, b2: [x, y]}) or list fully pinned nodes",
                   data, keys["pinned"])
    for k, (node, axes) in enumerate(raw_items):
        where = node if isinstance(raw, dict) else k
        i = _node_ref(node, index, "pinned", raw, where)
        if axes is True or (isinstance(axes, str) and axes.lower() in ("all", "xyz")):
            pinned[i] = True
            continue
        letters = list(axes) if isinstance(axes, str) else axes
        if not isinstance(letters, (list, tuple)) or not letters:
            raise _err(f"pinned axes of node {excerpt(node)} must be like xyz, xz or [x, y], got {excerpt(axes)}",
                       raw, where)
        for ax in letters:
            if not isinstance(ax, str) or ax.lower() not in ("x", "y", "z"):
                raise _err(f"pinned axes of node {excerpt(node)}: unknown axis {excerpt(ax)} (use x, y, z)",
                           raw, where)
            pinned[i, "xyz".index(ax.lower())] = True
    return pinned


def _read_bodies(data: Mapping[Any, Any], keys: Keys, index: Mapping[str, int]) -> list[RigidBody]:
    if "rigid_bodies" not in keys:
        return []
    raw = data[keys["rigid_bodies"]]
    if not isinstance(raw, list):
        raise _err("rigid_bodies must be a list of {name, nodes, mass, fixed}", data, keys["rigid_bodies"])
    out: list[RigidBody] = []
    for k, item in enumerate(raw):
        body = _body_inline(k, item, index)
        out.append(body if body is not None else _body_entry(k, item, raw, index))
    return out


def _body_inline(k: int, item: object, index: Mapping[str, int]) -> RigidBody | None:
    """A body entry of the common shape read without wording anything, or None."""
    if not isinstance(item, dict) or not item.keys() <= BODY_KEYS:
        return None
    name, nodes = item.get("name", f"body{k}"), item.get("nodes")
    mass, fixed = item.get("mass", 0.0), item.get("fixed", False)
    if type(name) is not str or not isinstance(nodes, list) or type(mass) not in _NUMBER_TYPES \
            or type(fixed) is not bool or not 0 <= mass <= MAX_MAGNITUDE:
        return None
    idx = [index.get(n) if type(n) is str else None for n in nodes]
    if None in idx:
        return None
    return RigidBody(name, tuple(cast(list[int], idx)), float(mass), fixed)   # no None: refused above


def _body_entry(k: int, item: object, raw: list[Any], index: Mapping[str, int]) -> RigidBody:
    """One body entry read with every check, worded."""
    if not isinstance(item, dict):
        raise _err(f"rigid_bodies[{k}] must be a mapping {{name, nodes, mass, fixed}}", raw, k)
    bk = _check_keys(item, BODY_KEYS, {}, f"rigid_bodies[{k}]")
    name = item[bk["name"]] if "name" in bk else f"body{k}"
    if isinstance(name, bool) or not isinstance(name, (str, int)):
        raise _err(f"rigid_bodies[{k}]: name must be a string, got {excerpt(name)}", raw, k)
    what = f"rigid body {excerpt(str(name))}"
    if "nodes" not in bk or not isinstance(item[bk["nodes"]], list):
        raise _err(f"{what}: nodes must be a list of node names", raw, k)
    nodes = tuple(_node_ref(n, index, what, raw, k) for n in item[bk["nodes"]])
    mass = _number(item[bk["mass"]], f"{what}: mass", raw, k, nonneg=True) if "mass" in bk else 0.0
    fixed = item.get(bk.get("fixed", "fixed"), False)
    if not isinstance(fixed, bool):
        raise _err(f"{what}: fixed must be true or false, got {excerpt(fixed)}", raw, k)
    return RigidBody(str(name), nodes, mass, fixed)


def _read_gravity(data: Mapping[Any, Any], keys: Keys) -> NDArray[np.float64]:
    if "gravity" not in keys:
        return np.zeros(3)
    raw = data[keys["gravity"]]
    if raw is True:
        return np.array([0.0, 0.0, -STANDARD_GRAVITY])
    if raw is False or raw is None:
        return np.zeros(3)
    if is_number(raw):
        return np.array([0.0, 0.0, -_number(raw, "gravity", data, keys["gravity"], nonneg=True)])
    return np.array(_vector(raw, "gravity", data, keys["gravity"]))
