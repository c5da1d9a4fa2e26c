"""Read structure descriptions (YAML or TOML files or text, or Python dicts).

The format is documented in ``docs/structures.md``. Every error is a
:class:`~tensegrity_core.general.structure.StructureError` that names the offending entry
and, for YAML, its line. PyYAML's YAML 1.1 quirk that reads ``7.6e10`` (no dot or sign in
the exponent) as a string is fixed: such scalars are numbers here.
"""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import numpy as np
import yaml

from tensegrity_core.general.structure import (
    KIND_ALIASES,
    RigidBody,
    Structure,
    StructureError,
    suggest,
)

TOP_KEYS = {"name", "units", "description", "defaults", "nodes", "members", "pinned",
            "rigid_bodies", "loads", "masses", "gravity"}
TOP_ALIASES = {"supports": "pinned", "bodies": "rigid_bodies", "point_masses": "masses"}
MEMBER_KEYS = {"name", "nodes", "type", "EA", "E", "A", "rest_length", "rest_length_ratio", "mass"}
MEMBER_ALIASES = {"ends": "nodes", "kind": "type", "l0": "rest_length", "l0_ratio": "rest_length_ratio"}
DEFAULT_KEYS = {"EA", "E", "A", "type", "rest_length_ratio", "mass"}
BODY_KEYS = {"name", "nodes", "mass", "fixed"}
STANDARD_GRAVITY = 9.80665


class _Located(dict):
    """A mapping that remembers the line of itself and of each key (1-based)."""

    line: int | None = None

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.key_lines: dict = {}


class _LocatedList(list):
    """A sequence that remembers the line of itself and of each item (1-based)."""

    line: int | None = None
    item_lines: list = []


class _Loader(yaml.SafeLoader):
    """SafeLoader that records lines, rejects duplicate keys and reads ``1e-4`` as a float."""


def _construct_map(loader, node):
    loader.flatten_mapping(node)
    out = _Located()
    out.line = node.start_mark.line + 1
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        line = key_node.start_mark.line + 1
        try:
            hash(key)
        except TypeError:
            raise StructureError(f"unhashable mapping key at line {line}", line=line) from None
        if key in out:
            raise StructureError(f"duplicate key {key!r} at line {line} (first at line {out.key_lines[key]})",
                                 line=line)
        out[key] = loader.construct_object(value_node, deep=True)
        out.key_lines[key] = line
    return out


def _construct_seq(loader, node):
    out = _LocatedList(loader.construct_object(child, deep=True) for child in node.value)
    out.line = node.start_mark.line + 1
    out.item_lines = [child.start_mark.line + 1 for child in node.value]
    return out


_Loader.add_constructor("tag:yaml.org,2002:map", _construct_map)
_Loader.add_constructor("tag:yaml.org,2002:seq", _construct_seq)
#: YAML 1.1 leaves ``7.6e10`` (no dot, no exponent sign) a string; both loaders read it as a float.
_EXPONENT_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$")
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789."))


class _FastLoader(yaml.CSafeLoader):
    """libyaml's C parser with the same duplicate-key check and float rule as :class:`_Loader`,
    but no line records: the fast path for well-formed descriptions (a 0.7 MB file in
    ~0.4 s instead of ~2 s, validation included). Errors are located by re-reading with :class:`_Loader`."""


def _construct_plain_map(loader, node):
    loader.flatten_mapping(node)
    out = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            hash(key)
        except TypeError:
            raise _NeedsLines from None
        if key in out:
            raise _NeedsLines
        out[key] = loader.construct_object(value_node, deep=True)
    return out


class _NeedsLines(Exception):
    """The fast path met a problem; the line-tracking parser reports it with its line."""


_FastLoader.add_constructor("tag:yaml.org,2002:map", _construct_plain_map)
_FastLoader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789."))


def _structure_from_text(text: str, fmt: str | None = None, default_name: str = "") -> Structure:
    """Parse and validate a description: YAML through libyaml first; only a description
    that fails (syntax, duplicate keys, validation) is read again by the line-tracking
    parser, whose error names the line."""
    fmt = fmt or ("toml" if _looks_like_toml(text) else "yaml")
    if fmt == "yaml":
        try:
            data = yaml.load(text, Loader=_FastLoader)  # noqa: S506 (CSafeLoader subclass)
            if isinstance(data, dict):
                return structure_from_dict(data, default_name=default_name)
        except (yaml.YAMLError, _NeedsLines, StructureError):
            pass
    return structure_from_dict(parse_text(text, fmt), default_name=default_name)


def _looks_like_toml(text: str) -> bool:
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        return bool(re.match(r'^(\[|[A-Za-z0-9_"\'.-]+\s*=)', s))
    return False


def parse_text(text: str, fmt: str | None = None) -> dict:
    """Parse YAML or TOML text into a dict (``fmt`` "yaml"/"toml" or guessed)."""
    fmt = fmt or ("toml" if _looks_like_toml(text) else "yaml")
    if fmt == "toml":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as err:
            raise StructureError(f"invalid TOML: {err}") from None
    else:
        try:
            data = yaml.load(text, Loader=_Loader)  # noqa: S506 (SafeLoader subclass)
        except yaml.MarkedYAMLError as err:
            line = err.problem_mark.line + 1 if err.problem_mark else None
            raise StructureError(f"invalid YAML at line {line}: {err.problem}", line=line) from None
        except yaml.YAMLError as err:
            raise StructureError(f"invalid YAML: {err}") from None
    if not isinstance(data, dict):
        raise StructureError(f"a structure description must be a mapping, got {type(data).__name__}")
    return data


def load_structure(source) -> Structure:
    """Load a :class:`Structure` from a path (``.yaml``/``.yml``/``.json``/``.toml``), YAML or
    TOML *text*, or a dict.

    Strings without a line break that end in a known suffix (or name an existing file) are
    paths; any other string is description text. Nodes and members keep the order of the
    description.
    """
    if isinstance(source, Structure):
        return source
    if isinstance(source, dict):
        return structure_from_dict(source)
    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source and (
            source.lower().endswith((".yaml", ".yml", ".toml", ".json")) or Path(source).is_file())):
        path = Path(source)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise StructureError(f"structure file not found: {str(path)!r}") from None
        except OSError as err:
            raise StructureError(f"cannot read structure file {str(path)!r}: {err.strerror}") from None
        fmt = "toml" if path.suffix.lower() == ".toml" else "yaml"
        try:
            return _structure_from_text(text, fmt, default_name=path.stem)
        except StructureError as err:
            raise StructureError(f"{path.name}: {err}", entry=err.entry, line=err.line) from None
    if isinstance(source, str):
        return _structure_from_text(source)
    raise StructureError(f"cannot load a structure from a {type(source).__name__}; give a path, "
                         f"YAML/TOML text or a dict")


# --------------------------------------------------------------------------- dict -> Structure
def _line_of(container, key) -> int | None:
    if isinstance(container, _Located):
        return container.key_lines.get(key, container.line)
    if isinstance(container, _LocatedList) and isinstance(key, int) and key < len(container.item_lines):
        return container.item_lines[key]
    return getattr(container, "line", None)


def _err(message: str, container=None, key=None, entry=()) -> StructureError:
    line = _line_of(container, key) if container is not None else None
    where = f" (line {line})" if line else ""
    return StructureError(message + where, entry=entry, line=line)


def _check_keys(d: dict, allowed: set, aliases: dict, what: str) -> dict:
    out = {}
    for key in d:
        canon = aliases.get(key, key)
        if canon not in allowed:
            raise _err(f"{what}: unknown key {key!r}{suggest(key, sorted(allowed))}; allowed: "
                       f"{', '.join(sorted(allowed))}", d, key)
        if canon in out:
            raise _err(f"{what}: {key!r} repeats {canon!r}", d, key)
        out[canon] = key
    return out


def _number(value, what: str, container=None, key=None, *, positive=False, nonneg=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _err(f"{what} must be a number, got {value!r}", container, key)
    x = float(value)
    if not math.isfinite(x):
        raise _err(f"{what} must be finite, got {value!r}", container, key)
    if positive and x <= 0:
        raise _err(f"{what} must be positive, got {value!r}", container, key)
    if nonneg and x < 0:
        raise _err(f"{what} must be >= 0, got {value!r}", container, key)
    return x


def _vector(value, what: str, container=None, key=None) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise _err(f"{what} must be a list of 3 numbers [x, y, z], got {value!r}", container, key)
    return [_number(v, what, container, key) for v in value]


def _mapping(value, what: str, container, key) -> dict:
    if not isinstance(value, dict):
        raise _err(f"{what} must be a mapping, got {type(value).__name__}", container, key)
    return value


def _node_ref(ref, names: dict, what: str, container, key) -> int:
    if isinstance(ref, bool) or not isinstance(ref, (str, int)):
        raise _err(f"{what}: a node reference must be a node name, got {ref!r}", container, key)
    name = str(ref)
    if name not in names:
        raise _err(f"{what}: unknown node {name!r}{suggest(name, names)}", container, key)
    return names[name]


def structure_from_dict(data: dict, *, default_name: str = "") -> Structure:
    """Validate a description dict (see ``docs/structures.md``) and build the structure."""
    if not isinstance(data, dict):
        raise StructureError(f"a structure description must be a mapping, got {type(data).__name__}")
    keys = _check_keys(data, TOP_KEYS, TOP_ALIASES, "structure")
    get = lambda k, default=None: data.get(keys[k], default) if k in keys else default  # noqa: E731
    name = get("name", default_name)
    if not isinstance(name, str):
        raise _err(f"name must be a string, got {name!r}", data, keys.get("name"))
    units = get("units", "SI")
    if not isinstance(units, str) or units.strip().upper() != "SI":
        raise _err(f"units: only SI (m, N, kg, s) is supported, got {units!r}", data, keys.get("units"))
    description = get("description", "")
    if not isinstance(description, str):
        raise _err("description must be a string", data, keys.get("description"))

    node_names, coords = _read_nodes(data, keys)
    index = {n: i for i, n in enumerate(node_names)}
    defaults = _read_defaults(data, keys)
    members = _read_members(data, keys, index, defaults, np.asarray(coords))
    pinned = _read_pinned(data, keys, index)
    bodies = _read_bodies(data, keys, index)
    loads = np.zeros((len(node_names), 3))
    for node, value in _mapping(get("loads", {}), "loads", data, keys.get("loads")).items():
        i = _node_ref(node, index, "loads", get("loads"), node)
        loads[i] = _vector(value, f"loads of node {node!r}", get("loads"), node)
    masses = np.zeros(len(node_names))
    for node, value in _mapping(get("masses", {}), "masses", data, keys.get("masses")).items():
        i = _node_ref(node, index, "masses", get("masses"), node)
        masses[i] = _number(value, f"point mass of node {node!r}", get("masses"), node, nonneg=True)
    gravity = _read_gravity(data, keys)

    def located(err: StructureError) -> StructureError:
        if err.line is not None or not err.entry:
            return err
        section = err.entry[0]
        container = data.get(keys.get(section, section)) if section in keys else None
        key = err.entry[1] if len(err.entry) > 1 else None
        line = _line_of(container, key) if container is not None else None
        if line is None:
            return err
        return StructureError(f"{err} (line {line})", entry=err.entry, line=line)

    try:
        return Structure(
            name=name, node_names=tuple(node_names), nodes=np.asarray(coords, dtype=float),
            member_names=tuple(m["name"] for m in members),
            members=np.array([m["nodes"] for m in members], dtype=np.int64).reshape(-1, 2),
            member_kinds=tuple(m["type"] for m in members),
            EA=np.array([m["EA"] for m in members]), rest_lengths=np.array([m["l0"] for m in members]),
            member_masses=np.array([m["mass"] for m in members]), pinned=pinned,
            bodies=tuple(bodies), loads=loads, node_masses=masses, gravity=gravity)
    except StructureError as err:
        raise located(err) from None


def _read_nodes(data, keys):
    if "nodes" not in keys:
        raise StructureError("the description has no 'nodes'")
    raw = data[keys["nodes"]]
    names, coords = [], []
    if isinstance(raw, dict):
        for name, xyz in raw.items():
            if isinstance(name, bool) or not isinstance(name, (str, int)):
                raise _err(f"node name must be a string, got {name!r}", raw, name)
            names.append(str(name))
            coords.append(_vector(xyz, f"coordinates of node {name!r}", raw, name))
    elif isinstance(raw, list):
        for i, xyz in enumerate(raw):
            names.append(str(i))
            coords.append(_vector(xyz, f"coordinates of node {i}", raw, i))
    else:
        raise _err("nodes must be a mapping name: [x, y, z] or a list of [x, y, z]", data, keys["nodes"])
    if not names:
        raise _err("nodes is empty", data, keys["nodes"])
    return names, coords


def _read_defaults(data, keys) -> dict:
    raw = data.get(keys["defaults"], {}) if "defaults" in keys else {}
    raw = _mapping(raw, "defaults", data, keys.get("defaults"))
    _check_keys(raw, DEFAULT_KEYS, {"kind": "type", "l0_ratio": "rest_length_ratio"}, "defaults")
    out = {}
    for key, value in raw.items():
        canon = {"kind": "type", "l0_ratio": "rest_length_ratio"}.get(key, key)
        if canon == "type":
            out[canon] = value
        else:
            out[canon] = _number(value, f"defaults: {key}", raw, key,
                                 positive=canon != "mass", nonneg=canon == "mass")
    return out


def _read_members(data, keys, index, defaults, coords):
    if "members" not in keys:
        raise StructureError("the description has no 'members'")
    raw = data[keys["members"]]
    if not isinstance(raw, list) or not raw:
        raise _err("members must be a non-empty list", data, keys["members"])
    out, seen = [], {}
    for i, item in enumerate(raw):
        if isinstance(item, (list, tuple)):
            item = {"nodes": item}
        if not isinstance(item, dict):
            raise _err(f"members[{i}] must be a mapping like {{nodes: [a, b], type: string}} or a "
                       f"pair [a, b], got {item!r}", raw, i)
        mk = _check_keys(item, MEMBER_KEYS, MEMBER_ALIASES, f"members[{i}]")
        val = lambda k: item[mk[k]] if k in mk else defaults.get(k)  # noqa: E731
        name = item[mk["name"]] if "name" in mk else f"m{i}"
        if isinstance(name, bool) or not isinstance(name, (str, int)):
            raise _err(f"members[{i}]: name must be a string, got {name!r}", raw, i)
        name = str(name)
        what = f"member {name!r}"
        if name in seen:
            raise _err(f"{what}: name used twice (members[{seen[name]}] and members[{i}])", raw, i)
        seen[name] = i
        if "nodes" not in mk:
            raise _err(f"{what}: missing 'nodes: [a, b]'", raw, i)
        ends = item[mk["nodes"]]
        if not isinstance(ends, (list, tuple)) or len(ends) != 2:
            raise _err(f"{what}: nodes must be a pair [a, b], got {ends!r}", raw, i)
        a, b = (_node_ref(e, index, what, raw, i) for e in ends)
        kind = val("type") if val("type") is not None else "string"
        if not isinstance(kind, str) or kind.lower() not in KIND_ALIASES:
            raise _err(f"{what}: unknown type {kind!r}; use one of bar, strut, string, cable, "
                       f"actuator{suggest(str(kind).lower(), KIND_ALIASES)}", raw, i)
        EA = _member_stiffness(item, mk, defaults, what, raw, i)
        length = float(np.linalg.norm(coords[b] - coords[a]))
        if "rest_length" in mk and "rest_length_ratio" in mk:
            raise _err(f"{what}: give rest_length or rest_length_ratio, not both", raw, i)
        if "rest_length" in mk:
            l0 = _number(item[mk["rest_length"]], f"{what}: rest_length", raw, i, positive=True)
        else:
            ratio = val("rest_length_ratio")
            ratio = 1.0 if ratio is None else _number(ratio, f"{what}: rest_length_ratio", raw, i, positive=True)
            l0 = ratio * length if length > 0 else 1.0
        mass = val("mass")
        mass = 0.0 if mass is None else _number(mass, f"{what}: mass", raw, i, nonneg=True)
        out.append({"name": name, "nodes": (a, b), "type": KIND_ALIASES[kind.lower()], "EA": EA,
                    "l0": l0, "mass": mass})
    return out


def _member_stiffness(item, mk, defaults, what, raw, i) -> float:
    has = lambda k: k in mk  # noqa: E731
    if has("EA") and (has("E") or has("A")):
        raise _err(f"{what}: give EA, or E and A, not both", raw, i)
    if has("EA"):
        return _number(item[mk["EA"]], f"{what}: EA", raw, i, positive=True)
    if has("E") or has("A"):
        E = item[mk["E"]] if has("E") else defaults.get("E")
        A = item[mk["A"]] if has("A") else defaults.get("A")
        if E is None or A is None:
            raise _err(f"{what}: axial stiffness needs both E and A (or EA)", raw, i)
        return _number(E, f"{what}: E", raw, i, positive=True) * _number(A, f"{what}: A", raw, i, positive=True)
    if "EA" in defaults:
        return defaults["EA"]
    if "E" in defaults and "A" in defaults:
        return defaults["E"] * defaults["A"]
    raise _err(f"{what}: axial stiffness missing: give EA, or E and A, in the member or in defaults", raw, i)


def _read_pinned(data, keys, index) -> np.ndarray:
    pinned = np.zeros((len(index), 3), dtype=bool)
    if "pinned" not in keys:
        return pinned
    raw = data[keys["pinned"]]
    if isinstance(raw, list):
        raw_items = [(node, "xyz") for node in raw]
        container = raw
    elif isinstance(raw, dict):
        raw_items = list(raw.items())
        container = raw
    else:
        raise _err("pinned must map node: axes (e.g. {b1: xyz, b2: [x, y]}) or list fully pinned nodes",
                   data, keys["pinned"])
    for k, (node, axes) in enumerate(raw_items):
        where = node if isinstance(raw, dict) else k
        i = _node_ref(node, index, "pinned", container, where)
        if axes is True or (isinstance(axes, str) and axes.lower() in ("all", "xyz")):
            pinned[i] = True
            continue
        letters = list(axes) if isinstance(axes, str) else axes
        if not isinstance(letters, (list, tuple)) or not letters:
            raise _err(f"pinned axes of node {node!r} must be like xyz, xz or [x, y], got {axes!r}",
                       container, where)
        for ax in letters:
            if not isinstance(ax, str) or ax.lower() not in ("x", "y", "z"):
                raise _err(f"pinned axes of node {node!r}: unknown axis {ax!r} (use x, y, z)", container, where)
            pinned[i, "xyz".index(ax.lower())] = True
    return pinned


def _read_bodies(data, keys, index) -> list[RigidBody]:
    if "rigid_bodies" not in keys:
        return []
    raw = data[keys["rigid_bodies"]]
    if not isinstance(raw, list):
        raise _err("rigid_bodies must be a list of {name, nodes, mass, fixed}", data, keys["rigid_bodies"])
    out = []
    for k, item in enumerate(raw):
        if not isinstance(item, dict):
            raise _err(f"rigid_bodies[{k}] must be a mapping {{name, nodes, mass, fixed}}", raw, k)
        bk = _check_keys(item, BODY_KEYS, {}, f"rigid_bodies[{k}]")
        name = str(item[bk["name"]]) if "name" in bk else f"body{k}"
        what = f"rigid body {name!r}"
        if "nodes" not in bk or not isinstance(item[bk["nodes"]], list):
            raise _err(f"{what}: nodes must be a list of node names", raw, k)
        nodes = tuple(_node_ref(n, index, what, raw, k) for n in item[bk["nodes"]])
        mass = _number(item[bk["mass"]], f"{what}: mass", raw, k, nonneg=True) if "mass" in bk else 0.0
        fixed = item.get(bk.get("fixed", "fixed"), False)
        if not isinstance(fixed, bool):
            raise _err(f"{what}: fixed must be true or false, got {fixed!r}", raw, k)
        out.append(RigidBody(name, nodes, mass, fixed))
    return out


def _read_gravity(data, keys) -> np.ndarray:
    if "gravity" not in keys:
        return np.zeros(3)
    raw = data[keys["gravity"]]
    if raw is True:
        return np.array([0.0, 0.0, -STANDARD_GRAVITY])
    if raw is False or raw is None:
        return np.zeros(3)
    if isinstance(raw, (int, float)) and not isinstance(raw, bool):
        return np.array([0.0, 0.0, -_number(raw, "gravity", data, keys["gravity"], nonneg=True)])
    return np.array(_vector(raw, "gravity", data, keys["gravity"]))


# --------------------------------------------------------------------------- Structure -> text
def structure_to_dict(structure: Structure) -> dict:
    """The description of ``structure`` as plain data (absolute rest lengths, EA per member);
    ``load_structure(structure_to_dict(s))`` rebuilds an equal structure."""
    s = structure
    out: dict = {"name": s.name, "units": "SI",
                 "nodes": {n: [float(v) for v in xyz] for n, xyz in zip(s.node_names, s.nodes)}}
    members = []
    for i, name in enumerate(s.member_names):
        a, b = s.members[i]
        m = {"name": name, "nodes": [s.node_names[a], s.node_names[b]], "type": s.member_kinds[i],
             "EA": float(s.EA[i]), "rest_length": float(s.rest_lengths[i])}
        if s.member_masses[i]:
            m["mass"] = float(s.member_masses[i])
        members.append(m)
    out["members"] = members
    pinned = {s.node_names[i]: "".join("xyz"[j] for j in range(3) if s.pinned[i, j])
              for i in range(s.n_nodes) if s.pinned[i].any()}
    if pinned:
        out["pinned"] = pinned
    if s.bodies:
        out["rigid_bodies"] = []
        for body in s.bodies:
            entry = {"name": body.name, "nodes": [s.node_names[i] for i in body.nodes]}
            if body.mass:
                entry["mass"] = float(body.mass)
            if body.fixed:
                entry["fixed"] = True
            out["rigid_bodies"].append(entry)
    loads = {s.node_names[i]: [float(v) for v in s.loads[i]] for i in range(s.n_nodes) if s.loads[i].any()}
    if loads:
        out["loads"] = loads
    masses = {s.node_names[i]: float(s.node_masses[i]) for i in range(s.n_nodes) if s.node_masses[i]}
    if masses:
        out["masses"] = masses
    if s.gravity.any():
        out["gravity"] = [float(v) for v in s.gravity]
    return out


def dump_structure(structure: Structure, header: str = "") -> str:
    """YAML text of ``structure`` in the hand-written style (one node or member per line),
    preceded by ``header`` as comment lines."""
    data = structure_to_dict(structure)
    flow = lambda v: yaml.safe_dump([v], default_flow_style=True, sort_keys=False,  # noqa: E731
                                    width=10_000).strip()[1:-1]
    lines = [f"# {h}" if h else "#" for h in header.splitlines()]
    for key, value in data.items():
        if isinstance(value, dict):
            lines.append(f"{key}:")
            lines += [f"  {flow(k)}: {flow(v)}" for k, v in value.items()]
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            lines.append(f"{key}:")
            lines += [f"  - {flow(v)}" for v in value]
        else:
            lines.append(f"{key}: {flow(value)}")
    return "\n".join(lines) + "\n"
