"""The immutable description of a general tensegrity structure (topology, stiffness, supports).

A :class:`Structure` holds everything that does not change while the structure deforms:
node names and the reference coordinates [m] (the drawn shape: the start of form-finding
and the body-fixed shape of every rigid body), members (node pairs, kind, axial stiffness
EA [N], rest length [m], mass [kg]), per-axis supports, rigid bodies, external nodal loads
[N], point masses [kg] and gravity [m/s^2]. The changing state (node coordinates) lives
apart, in :class:`tensegrity_core.general.configuration.Configuration` or plain ``(n, 3)``
arrays -- the MuJoCo model/data split.

Member kinds: ``"bar"`` carries tension and compression; ``"string"`` carries tension only
(slack, zero force and zero stiffness, when shorter than its rest length); ``"actuator"``
is a bar whose rest length is the control input. Member ``i`` runs from node
``members[i, 0]`` to node ``members[i, 1]``; its force is tension-positive,
``t = EA (l - l0) / l0``.

Rigid bodies need at least three non-collinear nodes (two nodes cannot fix an orientation:
model a two-node rigid link as a stiff bar). A body with ``fixed=True`` does not move; its
nodes act as fully pinned nodes. Individual nodes of a moving body cannot be pinned.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Final, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from tensegrity_core.general.dofs import DofLayout, StiffnessPattern
from tensegrity_core.schema import MAX_MAGNITUDE, KeyPath, SchemaError, excerpt, suggest

MEMBER_KINDS: Final = ("bar", "string", "actuator")
#: Standard gravity [m/s^2] (``gravity: true`` in a structure, the scenes' default).
STANDARD_GRAVITY: Final = 9.80665
KIND_ALIASES: Final = {"bar": "bar", "strut": "bar", "string": "string", "cable": "string",
                "tendon": "string", "actuator": "actuator"}


class StructureError(SchemaError):
    """A structure description is invalid.

    ``entry`` (also ``key``) locates the offending entry as a path (e.g. ``("members",
    3)``), ``line`` is the 1-based line of the description file when the parser knows it,
    ``file`` the file's name. Messages name members and nodes in words (``member 's3':
    ...``), so ``str()`` does not repeat the key path.
    """

    show_key = False

    def __init__(self, message: str, *, entry: KeyPath = (), key: KeyPath | None = None, line: int | None = None,
                 file: str | None = None) -> None:
        super().__init__(message, key=entry if key is None else key, line=line, file=file)

    @property
    def entry(self) -> KeyPath:
        return self.key


@dataclass(frozen=True)
class RigidBody:
    """A rigid body: the indices of its nodes, its mass [kg] (acting at the centroid of its
    nodes, the paper's Eq. 25) and whether it is fixed in space."""

    name: str
    nodes: tuple[int, ...]
    mass: float = 0.0
    fixed: bool = False


def _readonly(key: str, a: ArrayLike, dtype: DTypeLike = float) -> NDArray[Any]:
    """A read-only copy of field ``key``; :class:`StructureError` naming it if ``a`` is not an
    array of numbers."""
    try:
        a = np.array(a, dtype=dtype, copy=True)
    except (TypeError, ValueError):
        raise StructureError(f"{key} must be an array of numbers, got {excerpt(a)}", entry=(key,)) from None
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Structure:
    """Immutable structure description; build it with :meth:`from_arrays`,
    :func:`tensegrity_core.general.load_structure` or a generator.

    Array attributes are read-only. ``nodes`` (n, 3) are the reference coordinates [m];
    ``loads`` (n, 3) [N], ``node_masses`` (n,) [kg] and ``gravity`` (3,) [m/s^2] are given
    by keyword (:meth:`from_arrays` fills in zeros).
    """

    name: str
    node_names: tuple[str, ...]
    nodes: NDArray[np.float64]
    member_names: tuple[str, ...]
    members: NDArray[np.int64]
    member_kinds: tuple[str, ...]
    EA: NDArray[np.float64]
    rest_lengths: NDArray[np.float64]
    member_masses: NDArray[np.float64]
    pinned: NDArray[np.bool_]
    bodies: tuple[RigidBody, ...] = ()
    loads: NDArray[np.float64] = field(kw_only=True)
    node_masses: NDArray[np.float64] = field(kw_only=True)
    gravity: NDArray[np.float64] = field(kw_only=True)

    def __post_init__(self) -> None:
        n = len(self.node_names)
        m = len(self.member_names)

        def set_(k: str, v: object) -> None:      # a frozen dataclass
            object.__setattr__(self, k, v)

        set_("nodes", _readonly("nodes", self.nodes))
        set_("members", _readonly("members", self.members, dtype=np.int64))
        set_("EA", _readonly("EA", self.EA))
        set_("rest_lengths", _readonly("rest_lengths", self.rest_lengths))
        set_("member_masses", _readonly("member_masses", self.member_masses))
        set_("pinned", _readonly("pinned", self.pinned, dtype=bool))
        set_("loads", _readonly("loads", self.loads))
        set_("node_masses", _readonly("node_masses", self.node_masses))
        set_("gravity", _readonly("gravity", self.gravity))
        set_("member_kinds", tuple(self.member_kinds))
        set_("bodies", tuple(self.bodies))
        _validate(self, n, m)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_arrays(cls, nodes: ArrayLike, members: ArrayLike, *, EA: ArrayLike,
                    rest_lengths: ArrayLike | None = None, rest_length_ratio: ArrayLike | None = None,
                    kinds: str | Sequence[str] = "string", node_names: Iterable[str] | None = None,
                    member_names: Iterable[str] | None = None, pinned: ArrayLike | None = None,
                    bodies: Iterable[RigidBody | dict[str, Any]] = (), loads: ArrayLike | None = None,
                    node_masses: ArrayLike | None = None, member_masses: ArrayLike | None = None,
                    gravity: ArrayLike | None = None, name: str = "") -> Structure:
        """Build a structure from arrays (the fast path for generators).

        ``nodes`` (n, 3) [m]; ``members`` (m, 2) node indices; ``EA`` scalar or (m,) [N];
        either ``rest_lengths`` (m,) [m] or ``rest_length_ratio`` (scalar or (m,), times the
        member length in ``nodes``; default 1: stress-free as drawn); ``kinds`` one kind or
        (m,) kinds; ``pinned`` (n, 3) bool (or (n,) bool for fully pinned nodes); ``bodies``
        a sequence of :class:`RigidBody` or dicts ``{"name", "nodes", "mass", "fixed"}``.
        """
        xyz = np.asarray(nodes, dtype=np.float64)
        pairs = np.asarray(members)
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise StructureError(f"nodes must have shape (n, 3), got {xyz.shape}", entry=("nodes",))
        if pairs.ndim != 2 or pairs.shape[1] != 2 or pairs.dtype.kind not in "iu":
            raise StructureError(f"members must be an (m, 2) array of node indices, got shape "
                                 f"{pairs.shape} dtype {pairs.dtype}", entry=("members",))
        n, m = len(xyz), len(pairs)
        bad = (pairs < 0) | (pairs >= n)
        if bad.any():
            i = int(np.argwhere(bad.any(axis=1))[0, 0])
            raise StructureError(f"member #{i} refers to node index {pairs[i].tolist()}, "
                                 f"but there are {n} nodes", entry=("members", i))
        kind_list = [kinds] * m if isinstance(kinds, str) else kinds
        canonical = [_kind(k, ("members", i)) for i, k in enumerate(kind_list)]
        if len(canonical) != m:
            raise StructureError(f"kinds has {len(canonical)} entries for {m} members", entry=("members",))
        lengths = np.linalg.norm(xyz[pairs[:, 1]] - xyz[pairs[:, 0]], axis=1)
        if rest_lengths is not None and rest_length_ratio is not None:
            raise StructureError("give rest_lengths or rest_length_ratio, not both", entry=("members",))
        if rest_lengths is None:
            ratio = 1.0 if rest_length_ratio is None else rest_length_ratio
            rest_lengths = np.broadcast_to(np.asarray(ratio, dtype=float), (m,)) * lengths
        supports = np.zeros((n, 3), dtype=bool) if pinned is None else np.asarray(pinned, dtype=bool)
        if supports.shape == (n,):
            supports = np.repeat(supports[:, None], 3, axis=1)
        body_objs: list[RigidBody] = []
        for b, body in enumerate(bodies):
            if isinstance(body, dict):
                body = RigidBody(name=str(body.get("name", f"body{b}")),
                                 nodes=tuple(int(i) for i in body["nodes"]),
                                 mass=float(body.get("mass", 0.0)),
                                 fixed=bool(body.get("fixed", False)))
            body_objs.append(body)
        return cls(
            name=name,
            node_names=tuple(node_names) if node_names is not None else tuple(str(i) for i in range(n)),
            nodes=xyz,
            member_names=tuple(member_names) if member_names is not None else tuple(f"m{i}" for i in range(m)),
            members=pairs,
            member_kinds=tuple(canonical),
            EA=np.broadcast_to(np.asarray(EA, dtype=float), (m,)),
            rest_lengths=np.asarray(rest_lengths, dtype=float),
            member_masses=np.zeros(m) if member_masses is None else np.broadcast_to(
                np.asarray(member_masses, dtype=float), (m,)),
            pinned=supports,
            bodies=tuple(body_objs),
            loads=np.zeros((n, 3)) if loads is None else np.asarray(loads, dtype=np.float64),
            node_masses=np.zeros(n) if node_masses is None else np.asarray(node_masses, dtype=np.float64),
            gravity=np.zeros(3) if gravity is None else np.asarray(gravity, dtype=np.float64),
        )

    def replace(self, **changes: Any) -> Structure:
        """A copy with some fields changed (validated again), e.g. new ``rest_lengths``."""
        return dataclasses.replace(self, **changes)

    def with_rest_lengths(self, rest_lengths: ArrayLike) -> Structure:
        """A copy with new rest lengths [m] (actuation, prestress design, continuation)."""
        return self.replace(rest_lengths=rest_lengths)

    def with_nodes(self, nodes: ArrayLike) -> Structure:
        """A copy whose reference coordinates (start of form-finding, body shapes) are ``nodes``."""
        return self.replace(nodes=nodes)

    # ------------------------------------------------------------------ derived data
    @property
    def n_nodes(self) -> int:
        return len(self.node_names)

    @property
    def n_members(self) -> int:
        return len(self.member_names)

    @cached_property
    def is_string(self) -> NDArray[np.bool_]:
        """(m,) bool: members that go slack in compression."""
        return _readonly("is_string", [k == "string" for k in self.member_kinds], dtype=bool)

    @cached_property
    def initial_lengths(self) -> NDArray[np.float64]:
        """(m,) member lengths in the reference coordinates [m]."""
        h = self.nodes[self.members[:, 1]] - self.nodes[self.members[:, 0]]
        return _readonly("initial_lengths", np.linalg.norm(h, axis=1))

    @cached_property
    def external_forces(self) -> NDArray[np.float64]:
        """(n, 3) dead loads on the nodes [N]: applied loads plus the weight of point masses
        and of half of each member's mass (lumped at its ends)."""
        mass = self.node_masses.copy()
        np.add.at(mass, self.members[:, 0], 0.5 * self.member_masses)
        np.add.at(mass, self.members[:, 1], 0.5 * self.member_masses)
        return _readonly("external_forces", self.loads + mass[:, None] * self.gravity[None, :])

    @cached_property
    def layout(self) -> DofLayout:
        """The degrees of freedom (see :class:`tensegrity_core.general.dofs.DofLayout`)."""
        return DofLayout(self)

    @cached_property
    def stiffness_pattern(self) -> StiffnessPattern:
        """Sparsity pattern of the tangent stiffness (see :class:`tensegrity_core.general.dofs.StiffnessPattern`)."""
        return StiffnessPattern(self)

    def node_index(self, name: str) -> int:
        """Index of the node called ``name``."""
        try:
            return self.node_names.index(name)
        except ValueError:
            raise StructureError(f"unknown node {excerpt(name)}{suggest(name, self.node_names)}") from None

    def member_index(self, name: str) -> int:
        """Index of the member called ``name``."""
        try:
            return self.member_names.index(name)
        except ValueError:
            raise StructureError(f"unknown member {excerpt(name)}{suggest(name, self.member_names)}") from None

    def __repr__(self) -> str:
        return (f"Structure({excerpt(self.name)}: {self.n_nodes} nodes, {self.n_members} members, "
                f"{len(self.bodies)} rigid bodies, {self.layout.n_dof} DOF)")


def _kind(kind: object, entry: KeyPath) -> str:
    key = str(kind).lower()
    if key not in KIND_ALIASES:
        raise StructureError(f"unknown member type {excerpt(kind)}; use one of bar, strut, string, "
                             f"cable, actuator{suggest(key, KIND_ALIASES)}", entry=entry)
    return KIND_ALIASES[key]


def _validate(s: Structure, n: int, m: int) -> None:
    """Numeric invariants of a structure; each failure names the offending entry."""
    if n == 0:
        raise StructureError("the structure has no nodes", entry=("nodes",))
    if m == 0:
        raise StructureError("the structure has no members", entry=("members",))
    if len(set(s.node_names)) != n:
        dup = _first_repeat(s.node_names)
        raise StructureError(f"node name {excerpt(dup)} is used twice", entry=("nodes", dup))
    if len(set(s.member_names)) != m:
        dup = _first_repeat(s.member_names)
        raise StructureError(f"member name {excerpt(dup)} is used twice", entry=("members", s.member_names.index(dup)))
    shapes = {"nodes": (n, 3), "members": (m, 2), "EA": (m,), "rest_lengths": (m,),
              "member_masses": (m,), "pinned": (n, 3), "loads": (n, 3), "node_masses": (n,),
              "gravity": (3,)}
    for key, shape in shapes.items():
        if getattr(s, key).shape != shape:
            raise StructureError(f"{key} must have shape {shape}, got {getattr(s, key).shape}",
                                 entry=(key,))
    if len(s.member_kinds) != m or not set(s.member_kinds) <= set(MEMBER_KINDS):
        raise StructureError(f"member_kinds must be {m} of {MEMBER_KINDS}", entry=("members",))
    for key, arr, what, unit in (("nodes", s.nodes, "coordinates", "m"), ("loads", s.loads, "load", "N")):
        bad_rows = ~_bounded(arr).all(axis=1)
        if bad_rows.any():
            i = int(np.flatnonzero(bad_rows)[0])
            raise StructureError(f"{what} of node {excerpt(s.node_names[i])} must be finite and at most "
                                 f"{MAX_MAGNITUDE:g} {unit} in magnitude, got {arr[i].tolist()} {unit}",
                                 entry=(key, s.node_names[i]))
    if not _bounded(s.gravity).all():
        raise StructureError(f"gravity must be finite and at most {MAX_MAGNITUDE:g} m/s^2 in magnitude, got "
                             f"{s.gravity.tolist()} m/s^2", entry=("gravity",))
    a, b = s.members[:, 0], s.members[:, 1]
    if ((s.members < 0) | (s.members >= n)).any():
        i = int(np.flatnonzero(((s.members < 0) | (s.members >= n)).any(axis=1))[0])
        raise StructureError(f"member {excerpt(s.member_names[i])} refers to node index "
                             f"{s.members[i].tolist()}, but there are {n} nodes", entry=("members", i))
    same = np.flatnonzero(a == b)
    if same.size:
        i = int(same[0])
        raise StructureError(f"member {excerpt(s.member_names[i])} joins node {excerpt(s.node_names[a[i]])} to itself",
                             entry=("members", i))
    span = float(np.ptp(s.nodes, axis=0).max()) if n > 1 else 1.0
    if 0.0 < span < MIN_SPAN:
        raise StructureError(f"the nodes span {span:.3g} m, less than {MIN_SPAN:g} m: the squares of such lengths "
                             f"underflow double precision (give the coordinates in a smaller unit than m)",
                             entry=("nodes",))
    scale = max(span, 1e-300)
    delta = s.nodes[b] - s.nodes[a]
    big = np.abs(delta).max(axis=1)              # norms without squaring tiny components to 0
    lengths = np.linalg.norm(delta / np.where(big > 0, big, 1.0)[:, None], axis=1) * big
    short = np.flatnonzero(lengths <= 1e-12 * scale)
    if short.size:
        i = int(short[0])
        na, nb = excerpt(s.node_names[a[i]]), excerpt(s.node_names[b[i]])
        where = (f"are both at {s.nodes[a[i]].tolist()}" if np.array_equal(s.nodes[a[i]], s.nodes[b[i]]) else
                 f"at {s.nodes[a[i]].tolist()} and {s.nodes[b[i]].tolist()} are {float(lengths[i]):.3g} m apart, "
                 f"within 1e-12 of the structure's size {scale:.3g} m")
        raise StructureError(f"member {excerpt(s.member_names[i])} has zero length: nodes {na} and {nb} {where}",
                             entry=("members", i))
    for arr, what, unit in ((s.EA, "axial stiffness EA", "N"), (s.rest_lengths, "rest length", "m")):
        bad = np.flatnonzero(~_bounded(arr) | (arr <= 0))
        if bad.size:
            i = int(bad[0])
            value = float(arr[i])
            why = (f"must be at most {MAX_MAGNITUDE:g} {unit} (larger values overflow the squares the solvers "
                   f"form)" if math.isfinite(value) and value > 0 else f"must be finite and positive [{unit}]")
            raise StructureError(f"member {excerpt(s.member_names[i])}: {what} {why}, got {excerpt(value)} {unit}",
                                 entry=("members", i))
    bad = np.flatnonzero(~_bounded(s.member_masses) | (s.member_masses < 0))
    if bad.size:
        i = int(bad[0])
        raise StructureError(f"member {excerpt(s.member_names[i])}: mass must be finite and >= 0 kg, "
                             f"got {excerpt(float(s.member_masses[i]))} kg", entry=("members", i))
    bad = np.flatnonzero(~_bounded(s.node_masses) | (s.node_masses < 0))
    if bad.size:
        i = int(bad[0])
        raise StructureError(f"point mass of node {excerpt(s.node_names[i])} must be finite and >= 0 kg, "
                             f"got {excerpt(float(s.node_masses[i]))} kg", entry=("masses", s.node_names[i]))
    bodies = _body_nodes(s)
    _validate_bodies(s, n, scale, bodies)
    _validate_free_nodes(s, n, bodies)


#: Least span of a structure's nodes [m] (largest extent along an axis): below it the
#: squares of member lengths, which energies and stiffnesses form, underflow (a prism
#: form-finds down to 1e-154 m and fails its line search at 1e-156 m).
MIN_SPAN: Final = 1e-150


def _bounded(arr: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Elementwise: finite and at most MAX_MAGNITUDE in magnitude (larger values overflow
    the squares the solvers form)."""
    return np.isfinite(arr) & (np.abs(arr) <= MAX_MAGNITUDE)


def _first_repeat(names: Sequence[str]) -> str:
    """The first of ``names`` that occurs more than once."""
    counts = Counter(names)
    return next(x for x in names if counts[x] > 1)


#: ``(sizes, flat, body_of)`` of :func:`_body_nodes`.
BodyNodes: TypeAlias = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]


def _validate_bodies(s: Structure, n: int, scale: float, bodies: BodyNodes) -> None:
    """The rigid bodies' invariants, checked on all bodies at once (a 60,000-member spine
    has 7,500 bodies); each failure names the first offending body."""
    if not s.bodies:
        return
    names = [b.name for b in s.bodies]
    if len(set(names)) != len(names):
        dup = _first_repeat(names)
        k = names.index(dup)
        raise StructureError(f"rigid body name {excerpt(dup)} is used twice", entry=("rigid_bodies", k))
    sizes, flat, body_of = bodies
    masses = np.array([b.mass for b in s.bodies], dtype=float)
    bad = np.flatnonzero(~_bounded(masses) | (masses < 0))
    if bad.size:
        k = int(bad[0])
        raise StructureError(f"rigid body {excerpt(s.bodies[k].name)}: mass must be finite and >= 0 kg, "
                             f"got {excerpt(s.bodies[k].mass)} kg", entry=("rigid_bodies", k))
    bad = np.flatnonzero((flat < 0) | (flat >= n))
    if bad.size:
        body = s.bodies[body_of[bad[0]]]
        raise StructureError(f"rigid body {excerpt(body.name)} refers to node index {list(body.nodes)}, "
                             f"but there are {n} nodes", entry=("rigid_bodies", int(body_of[bad[0]])))
    _first_shared_node(s, flat, body_of)
    few = np.flatnonzero(sizes < 3)
    if few.size:
        k = int(few[0])
        raise StructureError(
            f"rigid body {excerpt(s.bodies[k].name)} has {sizes[k]} node(s); a rigid body needs at least 3 "
            f"non-collinear nodes to fix its orientation (model a 2-node rigid link as a stiff bar)",
            entry=("rigid_bodies", k))
    _first_collinear_body(s, sizes, scale)
    moving = ~np.array([b.fixed for b in s.bodies])
    pinned_in_moving = np.flatnonzero(moving[body_of] & s.pinned[flat].any(axis=1))
    if pinned_in_moving.size:
        j = int(pinned_in_moving[0])
        body = s.bodies[body_of[j]]
        raise StructureError(
            f"node {excerpt(s.node_names[flat[j]])} belongs to rigid body {excerpt(body.name)} and is pinned; pin "
            f"the whole body instead (fixed: true)", entry=("rigid_bodies", int(body_of[j])))
    owner = np.full(n, -1)
    owner[flat] = body_of
    a, b = s.members[:, 0], s.members[:, 1]
    inside = np.flatnonzero((owner[a] >= 0) & (owner[a] == owner[b]))
    if inside.size:
        i = int(inside[0])
        raise StructureError(
            f"member {excerpt(s.member_names[i])} joins nodes {excerpt(s.node_names[a[i]])} and "
            f"{excerpt(s.node_names[b[i]])} of the same rigid body {excerpt(s.bodies[owner[a[i]]].name)}: its "
            f"length cannot change, so it carries nothing; remove it", entry=("members", i))


def _first_shared_node(s: Structure, flat: NDArray[np.int64], body_of: NDArray[np.int64]) -> None:
    """A node listed twice by one body, or by two bodies."""
    order = np.argsort(flat, kind="stable")
    repeats = np.flatnonzero(flat[order][1:] == flat[order][:-1])
    if not repeats.size:
        return
    # the repeat that comes last in description order is where the old loop stopped first
    pairs = [(int(order[r]), int(order[r + 1])) for r in repeats]
    first, second = min(pairs, key=lambda p: p[1])
    k1, k2 = int(body_of[first]), int(body_of[second])
    if k1 == k2:
        raise StructureError(f"rigid body {excerpt(s.bodies[k2].name)} lists a node twice", entry=("rigid_bodies", k2))
    raise StructureError(f"node {excerpt(s.node_names[flat[second]])} is in two rigid bodies: "
                         f"{excerpt(s.bodies[k1].name)} and {excerpt(s.bodies[k2].name)}", entry=("rigid_bodies", k2))


def _first_collinear_body(s: Structure, sizes: NDArray[np.int64], scale: float) -> None:
    """A body whose nodes lie on a line (checked per group of bodies of one size, batched)."""
    bad: list[int] = []
    for size in np.unique(sizes):
        ks = np.flatnonzero(sizes == size)
        pts = s.nodes[np.array([s.bodies[k].nodes for k in ks])]            # (bodies, size, 3)
        pts = pts - pts.mean(axis=1, keepdims=True)
        sv = np.linalg.svd(pts, compute_uv=False)
        flat = (sv[:, 1] <= 1e-9 * np.maximum(sv[:, 0], 1e-300)) | (sv[:, 0] <= 1e-12 * scale)
        bad.extend(ks[flat].tolist())
    if bad:
        k = min(bad)
        raise StructureError(
            f"rigid body {excerpt(s.bodies[k].name)}: its nodes are collinear, so they cannot fix an "
            f"orientation; a rigid body needs at least 3 non-collinear nodes", entry=("rigid_bodies", k))


def _validate_free_nodes(s: Structure, n: int, bodies: BodyNodes) -> None:
    _, flat, body_of = bodies
    in_body = np.zeros(n, dtype=bool)
    in_body[flat] = True
    connected = np.zeros(n, dtype=bool)
    connected[s.members.ravel()] = True
    loose = np.flatnonzero(~in_body & ~connected & ~s.pinned.all(axis=1))
    if loose.size:
        i = int(loose[0])
        raise StructureError(f"node {excerpt(s.node_names[i])} is free but no member is attached to it",
                             entry=("nodes", s.node_names[i]))
    if s.bodies:
        attached = np.zeros(len(s.bodies), dtype=bool)
        attached[body_of[connected[flat]]] = True
        fixed = np.array([b.fixed for b in s.bodies])
        bad = np.flatnonzero(~fixed & ~attached)
        if bad.size:
            k = int(bad[0])
            raise StructureError(f"rigid body {excerpt(s.bodies[k].name)} is free but no member is attached to it",
                                 entry=("rigid_bodies", k))


def _body_nodes(s: Structure) -> BodyNodes:
    """``(sizes, flat, body_of)``: each body's node count, all bodies' nodes one after the
    other, and the body of each entry of ``flat``."""
    sizes = np.array([len(b.nodes) for b in s.bodies], dtype=np.int64)
    flat = np.fromiter((i for b in s.bodies for i in b.nodes), dtype=np.int64, count=int(sizes.sum()))
    return sizes, flat, np.repeat(np.arange(len(s.bodies)), sizes)
