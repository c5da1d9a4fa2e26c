"""The structure description's schema: parsed data (dict) to a :class:`Structure`.

The format is documented in ``docs/structures.md``. This module reads the nodes, defaults,
supports, rigid bodies, loads, point masses and gravity; the members, in either of their
two forms, are :mod:`~tensegrity_core.general.member_schema`'s. Both check whole columns
with numpy where they can (the nodes' coordinates as one array; a rigid body of the common
shape without wording anything) and word an error only for the entry that fails. Every
check is a :class:`~tensegrity_core.schema.Reader`'s; errors are :class:`StructureError`
naming the entry in words (``member 's3': ...``), with its key path and, for YAML, its
line. The :class:`Structure` then checks what involves several entries (a member joining a
node to itself, a rigid body's nodes), located here by the entry it names.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Final, cast

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.member_schema import MEMBER_UNITS, Keys, MemberReader, member_count
from tensegrity_core.general.structure import STANDARD_GRAVITY, RigidBody, Structure, StructureError
from tensegrity_core.schema import MAX_MAGNITUDE, excerpt, is_number, line_of, number_rows, type_name
from tensegrity_core.schema.columns import NUMBER_TYPES

TOP_KEYS: Final = ("defaults", "description", "gravity", "loads", "masses", "members", "name", "node_names", "nodes",
                   "pinned", "rigid_bodies", "units")
TOP_ALIASES: Final = {"supports": "pinned", "bodies": "rigid_bodies", "point_masses": "masses"}
DEFAULT_KEYS: Final = ("A", "E", "EA", "mass", "rest_length_ratio", "type")
DEFAULT_ALIASES: Final = {"kind": "type", "l0_ratio": "rest_length_ratio"}
BODY_KEYS: Final = ("fixed", "mass", "name", "nodes")


def structure_from_dict(data: object, *, default_name: str = "", max_members: int | None = None) -> Structure:
    """Validate a description dict (see ``docs/structures.md``) and build the structure.

    ``max_members``: refuse descriptions with more members, before reading them."""
    return _StructureReader().structure(data, default_name, max_members)


class _StructureReader(MemberReader):
    """The structure's schema: the members' part (:class:`MemberReader`) and the rest."""

    def structure(self, data: object, default_name: str, max_members: int | None) -> Structure:
        d = self.mapping(data, (), entry="a structure description")
        keys = self.keys(d, (), TOP_KEYS, aliases=TOP_ALIASES, entry="structure")

        def get(k: str, default: Any = None) -> Any:
            return d.get(keys[k], default) if k in keys else default

        if max_members is not None and "members" in keys:
            count = member_count(d[keys["members"]])
            if count > max_members:
                raise self.error(f"the structure has {count} members, more than the limit of {max_members}",
                                 ("members",), d, keys["members"])
        name = get("name", default_name)
        if not isinstance(name, str):
            raise self.error(f"name must be a string, got {excerpt(name)}", ("name",), d, keys.get("name"))
        units = get("units", "SI")
        if not isinstance(units, str) or units.strip().upper() != "SI":
            raise self.error(f"units: only SI (m, N, kg, s) is supported, got {excerpt(units)}", ("units",), d,
                             keys.get("units"))
        if not isinstance(get("description", ""), str):
            raise self.error("description must be a string", ("description",), d, keys.get("description"))

        node_names, coords = self.nodes(d, keys)
        index = {n: i for i, n in enumerate(node_names)}
        defaults = self.defaults(d, keys)
        if "members" not in keys:
            raise self.error("the description has no 'members'", ())
        member_names, pairs, kinds, EA, l0, mass = self.members(d[keys["members"]], ("members",), d, keys["members"],
                                                                index, defaults, coords)
        pinned = self.pinned(d, keys, index)
        bodies = self.bodies(d, keys, index)
        loads = np.zeros((len(node_names), 3))
        raw_loads = self.mapping(get("loads", {}), ("loads",), d, keys.get("loads"), entry="loads")
        for node, value in raw_loads.items():
            i = self.node_ref(node, index, "loads", ("loads", node), raw_loads, node)
            loads[i] = self.vector(value, 3, ("loads", node), raw_loads, node, unit="N", what="numbers [x, y, z]",
                                   entry=f"loads of node {excerpt(node)}")
        masses = np.zeros(len(node_names))
        raw_masses = self.mapping(get("masses", {}), ("masses",), d, keys.get("masses"), entry="masses")
        for node, value in raw_masses.items():
            i = self.node_ref(node, index, "masses", ("masses", node), raw_masses, node)
            masses[i] = self.number_at(value, f"point mass of node {excerpt(node)}", ("masses", node), raw_masses,
                                       node, unit="kg", nonneg=True)
        gravity = self.gravity(d, keys)
        try:
            return Structure(
                name=name, node_names=tuple(node_names), nodes=coords, member_names=tuple(member_names),
                members=pairs, member_kinds=tuple(kinds), EA=EA, rest_lengths=l0, member_masses=mass,
                pinned=pinned, bodies=tuple(bodies), loads=loads, node_masses=masses, gravity=gravity)
        except StructureError as err:
            raise _locate(err, d, keys, node_names) from None

    # -- nodes -------------------------------------------------------------------------------------
    def nodes(self, d: Mapping[Any, Any], keys: Keys) -> tuple[list[str], NDArray[np.float64]]:
        """``(names, coordinates (n, 3) [m])``: ``nodes`` as a mapping ``name: [x, y, z]``, or as a
        list of coordinates named by ``node_names`` (else "0", "1", ...)."""
        if "nodes" not in keys:
            raise self.error("the description has no 'nodes'", ())
        raw = d[keys["nodes"]]
        if isinstance(raw, dict):
            if "node_names" in keys:
                raise self.error("node_names goes with nodes as a list of [x, y, z]; here nodes are named already",
                                 ("node_names",), d, keys["node_names"])
            names: list[str] = []
            for name in raw:
                if isinstance(name, bool) or not isinstance(name, (str, int)):
                    raise self.error(f"node name must be a string, got {excerpt(name)}", ("nodes", name), raw, name)
                names.append(str(name))
            rows: list[Any] = list(raw.values())
            labels: list[Any] = list(raw)
        elif isinstance(raw, list):
            names = self.node_names(d, keys, len(raw))
            rows, labels = raw, list(range(len(raw)))
        else:
            raise self.error("nodes must be a mapping name: [x, y, z] or a list of [x, y, z]", ("nodes",), d,
                             keys["nodes"])
        if not names:
            raise self.error("nodes is empty", ("nodes",), d, keys["nodes"])
        coords = number_rows(rows, 3)
        if coords is None:            # an unusual row (numpy numbers, tuples) or a bad one, worded
            coords = np.array([self.vector(row, 3, ("nodes", label), raw, label, unit="m", what="numbers [x, y, z]",
                                           entry=f"coordinates of node {excerpt(label)}")
                               for label, row in zip(labels, rows)])
        return names, coords

    def node_names(self, d: Mapping[Any, Any], keys: Keys, n: int) -> list[str]:
        """``node_names`` (with nodes as a list of coordinates), or "0", "1", ..."""
        if "node_names" not in keys:
            return [str(i) for i in range(n)]
        raw = d[keys["node_names"]]
        if not isinstance(raw, list) or len(raw) != n:
            raise self.error(f"node_names must be a list of {n} names (one per node), got {type_name(raw)} "
                             f"({excerpt(raw)})",
                             ("node_names",), d, keys["node_names"])
        for i, name in enumerate(raw):
            if isinstance(name, bool) or not isinstance(name, (str, int)):
                raise self.error(f"node_names[{i}] must be a string, got {excerpt(name)}", ("node_names", i), raw, i)
        return [str(name) for name in raw]

    # -- defaults ----------------------------------------------------------------------------------
    def defaults(self, d: Mapping[Any, Any], keys: Keys) -> dict[str, Any]:
        """``defaults`` of the members: numbers (EA, E, A and the ratio > 0, mass >= 0) and a type."""
        raw = self.mapping(d.get(keys["defaults"], {}) if "defaults" in keys else {}, ("defaults",), d,
                           keys.get("defaults"), entry="defaults")
        self.keys(raw, ("defaults",), DEFAULT_KEYS, aliases=DEFAULT_ALIASES, entry="defaults")
        out: dict[str, Any] = {}
        for key, value in raw.items():
            canon = DEFAULT_ALIASES.get(key, key)
            if canon == "type":
                out[canon] = value
            else:
                out[canon] = self.number_at(value, f"defaults: {key}", ("defaults", key), raw, key,
                                            unit=MEMBER_UNITS[canon], positive=canon != "mass",
                                            nonneg=canon == "mass")
        return out

    # -- supports, bodies, gravity -----------------------------------------------------------------
    def pinned(self, d: Mapping[Any, Any], keys: Keys, index: Mapping[str, int]) -> NDArray[np.bool_]:
        """``pinned``: node -> axes (``xyz``, ``xz``, ``[x, y]``, ``all``, true), or a list of
        fully pinned nodes."""
        pinned = np.zeros((len(index), 3), dtype=bool)
        if "pinned" not in keys:
            return pinned
        raw = d[keys["pinned"]]
        raw_items: list[tuple[Any, Any]]
        if isinstance(raw, list):
            raw_items = [(node, "xyz") for node in raw]
        elif isinstance(raw, dict):
            raw_items = list(raw.items())
        else:
            raise self.error("pinned must map node: axes (e.g. {b1: xyz, b2: [x, y]}) or list fully pinned nodes",
                             ("pinned",), d, keys["pinned"])
        for k, (node, axes) in enumerate(raw_items):
            where = node if isinstance(raw, dict) else k
            path = ("pinned", where)
            i = self.node_ref(node, index, "pinned", path, raw, where)
            if axes is True or (isinstance(axes, str) and axes.lower() in ("all", "xyz")):
                pinned[i] = True
                continue
            letters = list(axes) if isinstance(axes, str) else axes
            if not isinstance(letters, (list, tuple)) or not letters:
                raise self.error(f"pinned axes of node {excerpt(node)} must be like xyz, xz or [x, y], got "
                                 f"{excerpt(axes)}", path, raw, where)
            for ax in letters:
                if not isinstance(ax, str) or ax.lower() not in ("x", "y", "z"):
                    raise self.error(f"pinned axes of node {excerpt(node)}: unknown axis {excerpt(ax)} (use x, y, z)",
                                     path, raw, where)
                pinned[i, "xyz".index(ax.lower())] = True
        return pinned

    def bodies(self, d: Mapping[Any, Any], keys: Keys, index: Mapping[str, int]) -> list[RigidBody]:
        """``rigid_bodies``: a list of ``{name, nodes, mass, fixed}``."""
        if "rigid_bodies" not in keys:
            return []
        raw = d[keys["rigid_bodies"]]
        if not isinstance(raw, list):
            raise self.error("rigid_bodies must be a list of {name, nodes, mass, fixed}", ("rigid_bodies",), d,
                             keys["rigid_bodies"])
        out: list[RigidBody] = []
        for k, item in enumerate(raw):
            body = _body_inline(k, item, index)
            out.append(body if body is not None else self.body_entry(k, item, raw, index))
        return out

    def body_entry(self, k: int, item: object, raw: list[Any], index: Mapping[str, int]) -> RigidBody:
        """One body entry read with every check, worded."""
        path = ("rigid_bodies", k)
        if not isinstance(item, dict):
            raise self.error(f"rigid_bodies[{k}] must be a mapping {{name, nodes, mass, fixed}}", path, raw, k)
        bk = self.keys(item, path, BODY_KEYS, entry=f"rigid_bodies[{k}]")
        name = item[bk["name"]] if "name" in bk else f"body{k}"
        if isinstance(name, bool) or not isinstance(name, (str, int)):
            raise self.error(f"rigid_bodies[{k}]: name must be a string, got {excerpt(name)}", path, raw, k)
        what = f"rigid body {excerpt(str(name))}"
        if "nodes" not in bk or not isinstance(item[bk["nodes"]], list):
            raise self.error(f"{what}: nodes must be a list of node names", path, raw, k)
        nodes = tuple(self.node_ref(n, index, what, path, raw, k) for n in item[bk["nodes"]])
        mass = self.number_at(item[bk["mass"]], f"{what}: mass", path, raw, k, unit="kg",
                                                                         nonneg=True) if "mass" in bk else 0.0
        fixed = item.get(bk.get("fixed", "fixed"), False)
        if not isinstance(fixed, bool):
            raise self.error(f"{what}: fixed must be true or false, got {excerpt(fixed)}", path, raw, k)
        return RigidBody(str(name), nodes, mass, fixed)

    def gravity(self, d: Mapping[Any, Any], keys: Keys) -> NDArray[np.float64]:
        """``gravity`` [m/s^2]: true (standard, along -z), false, a magnitude along -z or a vector."""
        if "gravity" not in keys:
            return np.zeros(3)
        raw = d[keys["gravity"]]
        if raw is True:
            return np.array([0.0, 0.0, -STANDARD_GRAVITY])
        if raw is False or raw is None:
            return np.zeros(3)
        if is_number(raw):
            return np.array([0.0, 0.0, -self.number_at(raw, "gravity", ("gravity",), d, keys["gravity"],
                                                       unit="m/s^2", nonneg=True)])
        return np.array(self.vector(raw, 3, ("gravity",), d, keys["gravity"], unit="m/s^2", what="numbers [x, y, z]",
                                    entry="gravity"))


def _body_inline(k: int, item: object, index: Mapping[str, int]) -> RigidBody | None:
    """A body entry of the common shape read without wording anything, or None."""
    if not isinstance(item, dict) or not item.keys() <= set(BODY_KEYS):
        return None
    name, nodes = item.get("name", f"body{k}"), item.get("nodes")
    mass, fixed = item.get("mass", 0.0), item.get("fixed", False)
    if type(name) is not str or not isinstance(nodes, list) or type(mass) not in NUMBER_TYPES \
            or type(fixed) is not bool or not 0 <= mass <= MAX_MAGNITUDE:
        return None
    idx = [index.get(n) if type(n) is str else None for n in nodes]
    if None in idx:
        return None
    return RigidBody(name, tuple(cast(list[int], idx)), float(mass), fixed)   # no None: refused above


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
