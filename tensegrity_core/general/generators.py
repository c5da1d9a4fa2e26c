"""Generators of the paper's example structures and of large structures for benchmarks.

Material: the paper (Sect. 5.2) gives strings E = 7.6e10 Pa, A = 1e-4 m^2, so
``EA = 7.6e6 N``; the same is used for bars unless stated. Geometries whose figures are
missing from the paper are chosen here and documented in ``docs/general.md``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull

from tensegrity_core.general.rotation import exp_so3
from tensegrity_core.general.structure import RigidBody, Structure, StructureError

PAPER_EA = 7.6e10 * 1.0e-4     # [N]
FloatArray = NDArray[np.float64]


def t_bar(top_ratio: float = 0.8, *, supports: str = "roller", length: float = 2.0,
          width: float = 1.0, EA: float = PAPER_EA) -> Structure:
    """Skelton's T-bar (Sect. 5.2.1): 4 bars + 4 strings in the x-z plane.

    Nodes: ends ``n1 = (-L/2, 0, 0)``, ``n2 = (L/2, 0, 0)``, centre ``n5`` at the origin,
    tips ``n3 = (0, 0, w/2)`` (top) and ``n4 = (0, 0, -w/2)`` (bottom). Bars n1-n5, n5-n2
    (the compressive axis) and n5-n3, n5-n4 (the T); strings n1-n3, n3-n2 (top) and
    n2-n4, n4-n1 (bottom). Rest lengths: bars = present length ``l``, bottom strings
    ``0.8 l``, top strings ``top_ratio * l`` (the paper steps it from 0.8 to 0.5).
    Every node is pinned in y (planar analysis). ``supports``: ``"roller"`` (n1 pinned in
    x and z, n2 in z: statically determinate) or ``"pinned"`` (both ends pinned in x, z).
    """
    if supports not in ("roller", "pinned"):
        raise StructureError(f"supports must be 'roller' or 'pinned', got {supports!r}")
    L, w = float(length), float(width)
    nodes = np.array([[-L / 2, 0, 0], [L / 2, 0, 0], [0, 0, w / 2], [0, 0, -w / 2], [0, 0, 0]])
    members = np.array([[0, 4], [4, 1], [4, 2], [4, 3], [0, 2], [2, 1], [1, 3], [3, 0]])
    ratio = np.array([1, 1, 1, 1, top_ratio, top_ratio, 0.8, 0.8], dtype=float)
    pinned = np.zeros((5, 3), dtype=bool)
    pinned[:, 1] = True
    pinned[0, [0, 2]] = True
    pinned[1, 2] = True
    if supports == "pinned":
        pinned[1, 0] = True
    return Structure.from_arrays(
        nodes, members, EA=EA, rest_length_ratio=ratio, kinds=["bar"] * 4 + ["string"] * 4,
        node_names=("n1", "n2", "n3", "n4", "n5"),
        member_names=("bar15", "bar52", "bar53", "bar54", "top13", "top32", "bottom24", "bottom41"),
        pinned=pinned, name=f"T-bar ({supports} supports, top strings {top_ratio:g} l)")


def tensegrity_table(*, radius: float = 1.0, height: float = 1.0, post_top: float = 0.75,
                     post_bottom: float = 0.25, ratio: float = 0.3, EA: float = PAPER_EA) -> Structure:
    """The tensegrity table (Sect. 5.2.3): two rigid bodies, three long strings and one short.

    Bottom body: three feet on a circle of ``radius`` at z = 0 (angles 90, 210, 330 deg) and
    a post tip on the axis at ``post_top``. Top body: three corners straight above the feet
    at ``height`` and a post tip hanging down to ``post_bottom`` (< ``post_top``). Long
    strings join each foot to the corner above; the short string joins the two post tips
    and lifts the top body. Rest lengths ``ratio`` times the drawn lengths (paper: 0.3).
    Unsupported: six rigid-body modes.
    """
    ang = np.deg2rad([90.0, 210.0, 330.0])
    ring = np.c_[radius * np.cos(ang), radius * np.sin(ang), np.zeros(3)]
    nodes = np.vstack([ring, [[0, 0, post_top]], ring + [0, 0, height], [[0, 0, post_bottom]]])
    names = ("f1", "f2", "f3", "post", "c1", "c2", "c3", "hang")
    members = np.array([[0, 4], [1, 5], [2, 6], [7, 3]])
    return Structure.from_arrays(
        nodes, members, EA=EA, rest_length_ratio=ratio, kinds="string", node_names=names,
        member_names=("long1", "long2", "long3", "short"),
        bodies=[RigidBody("bottom", (0, 1, 2, 3)), RigidBody("top", (4, 5, 6, 7))],
        name="tensegrity table")


# --------------------------------------------------------------------------- polyhedra
_PHI = (1 + 5 ** 0.5) / 2


def polyhedron(kind: str) -> tuple[FloatArray, list[list[int]]]:
    """Vertices (unit circumradius) and faces (vertex lists, counter-clockwise seen from
    outside) of a regular polyhedron: tetrahedron, hexahedron, octahedron, dodecahedron,
    icosahedron."""
    p, ip = _PHI, 1 / _PHI

    def signs(*k: int) -> FloatArray:
        """All sign combinations of ``len(k)`` entries, one per row."""
        return np.array(np.meshgrid(*[[-1.0, 1.0]] * len(k))).reshape(len(k), -1).T

    if kind == "tetrahedron":
        V = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    elif kind in ("hexahedron", "cube"):
        V = signs(1, 1, 1).astype(float)
    elif kind == "octahedron":
        V = np.vstack([np.eye(3), -np.eye(3)])
    elif kind == "dodecahedron":
        s2 = signs(1, 1)
        V = np.vstack([signs(1, 1, 1),
                       np.c_[np.zeros(4), s2[:, 0] * ip, s2[:, 1] * p],
                       np.c_[s2[:, 0] * ip, s2[:, 1] * p, np.zeros(4)],
                       np.c_[s2[:, 0] * p, np.zeros(4), s2[:, 1] * ip]]).astype(float)
    elif kind == "icosahedron":
        s2 = signs(1, 1)
        V = np.vstack([np.c_[np.zeros(4), s2[:, 0], s2[:, 1] * p],
                       np.c_[s2[:, 0], s2[:, 1] * p, np.zeros(4)],
                       np.c_[s2[:, 0] * p, np.zeros(4), s2[:, 1]]]).astype(float)
    else:
        raise StructureError(f"unknown polyhedron {kind!r}; choose tetrahedron, hexahedron, "
                             f"octahedron, dodecahedron or icosahedron")
    V = V / np.linalg.norm(V[0])
    hull = ConvexHull(V)
    faces: dict[tuple[float, ...], set[int]] = {}
    for simplex, eq in zip(hull.simplices, hull.equations):
        faces.setdefault(tuple(np.round(eq[:3], 6)), set()).update(simplex.tolist())
    out = []
    for normal, members in faces.items():
        verts = np.array(sorted(members))
        n = np.array(normal) / np.linalg.norm(normal)
        c = V[verts].mean(axis=0)
        e1 = V[verts[0]] - c
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        ang = np.arctan2((V[verts] - c) @ e2, (V[verts] - c) @ e1)
        out.append(verts[np.argsort(ang)].tolist())
    return V, out


def spherical_tensegrity(kind: str = "tetrahedron", *, phi_deg: float = 20.0, radius: float = 1.0,
                         vertical_ratio: float = 0.8, truncating_ratio: float = 1.0,
                         rigid: bool = True, bar_EA: float = 1000 * PAPER_EA,
                         EA: float = PAPER_EA) -> Structure:
    """Spherical tensegrity with rigid bodies on a regular polyhedron (Sect. 5.2.4).

    One rigid polygon per face, its nodes at the face's vertices, turned by ``phi_deg``
    about the face normal (counter-clockwise seen from outside). Truncating-edge strings
    join, around each vertex, the nodes of consecutive faces that met there (12 for the
    tetrahedron); one vertical string per edge joins the node of one adjacent face at one
    end of the edge to the node of the other face at the other end (6 for the
    tetrahedron), choosing the diagonal that the rotation shortens. Rest lengths: vertical
    ``vertical_ratio`` and truncating ``truncating_ratio`` times the drawn lengths.
    ``rigid=False`` builds the paper's traditional counterpart (TTS): each polygon becomes
    a ring of bars with axial stiffness ``bar_EA`` (1000 x the strings) plus, for polygons
    with more than three sides, bars from the first node to the others so it stays rigid.
    """
    V, faces = polyhedron(kind)
    V = V * radius
    phi = np.deg2rad(phi_deg)
    points: list[FloatArray] = []
    names: list[str] = []
    face_node: dict[tuple[int, int], int] = {}
    for f, verts in enumerate(faces):
        c = V[verts].mean(axis=0)
        n = c / np.linalg.norm(c)
        R = exp_so3(phi * n)
        for v in verts:
            face_node[(f, v)] = len(points)
            points.append(c + R @ (V[v] - c))
            names.append(f"f{f}v{v}")
    nodes = np.array(points)
    vertex_faces: dict[int, list[int]] = {}
    for f, verts in enumerate(faces):
        for v in verts:
            vertex_faces.setdefault(v, []).append(f)
    truncating: list[tuple[int, int]] = []
    for v, fs in vertex_faces.items():
        d = V[v] / np.linalg.norm(V[v])
        cs = np.array([V[faces[f]].mean(axis=0) for f in fs])
        e1 = cs[0] - d * (cs[0] @ d)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(d, e1)
        order = [fs[i] for i in np.argsort(np.arctan2(cs @ e2, cs @ e1))]
        k = len(order)
        pairs = [(order[i], order[(i + 1) % k]) for i in range(k)] if k > 2 else [(order[0], order[1])]
        truncating += [(face_node[(a, v)], face_node[(b, v)]) for a, b in pairs]
    edges: dict[tuple[int, int], list[int]] = {}
    for f, verts in enumerate(faces):
        for i in range(len(verts)):
            a, b = sorted((verts[i], verts[(i + 1) % len(verts)]))
            edges.setdefault((a, b), []).append(f)

    def length(pair: tuple[int, int]) -> float:
        return float(np.linalg.norm(nodes[pair[0]] - nodes[pair[1]]))

    vertical: list[tuple[int, int]] = []
    for (v1, v2), (fa, fb) in edges.items():
        d1 = (face_node[(fa, v1)], face_node[(fb, v2)])
        d2 = (face_node[(fa, v2)], face_node[(fb, v1)])
        vertical.append(d1 if length(d1) < length(d2) else d2)
    members = truncating + vertical
    kinds = ["string"] * len(members)
    ratios = [truncating_ratio] * len(truncating) + [vertical_ratio] * len(vertical)
    EAs = [EA] * len(members)
    member_names = [f"t{i}" for i in range(len(truncating))] + [f"v{i}" for i in range(len(vertical))]
    bodies: list[RigidBody] = []
    if rigid:
        bodies = [RigidBody(f"face{f}", tuple(face_node[(f, v)] for v in verts)) for f, verts in enumerate(faces)]
    else:
        for f, verts in enumerate(faces):
            ids = [face_node[(f, v)] for v in verts]
            ring = [(ids[i], ids[(i + 1) % len(ids)]) for i in range(len(ids))]
            braces = [(ids[0], ids[i]) for i in range(2, len(ids) - 1)]
            for j, (a, b) in enumerate(ring + braces):
                members.append((a, b))
                kinds.append("bar")
                ratios.append(1.0)
                EAs.append(bar_EA)
                member_names.append(f"b{f}_{j}")
    return Structure.from_arrays(
        nodes, np.array(members), EA=np.array(EAs), rest_length_ratio=np.array(ratios),
        kinds=kinds, node_names=names, member_names=member_names, bodies=bodies,
        name=f"spherical {kind} ({'rigid bodies' if rigid else 'bars'}), phi = {phi_deg:g} deg")


# --------------------------------------------------------------------------- prism tower
def prism_tower(n_stages: int, *, sides: int = 6, radius: float = 1.0, stage_height: float = 1.0,
                prestrain: float = 0.01, EA: float = PAPER_EA, bar_EA: float | None = None,
                free: bool = False) -> Structure:
    """A tower of ``n_stages`` stacked ``sides``-prisms, drawn in its prestressed equilibrium.

    ``n_stages + 1`` horizontal rings of ``sides`` nodes on a circle of ``radius``, ring
    ``k`` at ``z = k stage_height``, its nodes at angles ``2 pi i / sides``, turned by
    ``alpha = pi/2 + pi/sides`` on odd rings. Stage ``k`` (between rings ``k-1`` and ``k``) has
    ``sides`` bars (node ``i`` to node ``i``) and ``sides`` vertical strings (node ``i`` of the
    lower ring to node ``i - 1`` of the upper one on odd stages, to ``i + 1`` on even ones:
    each stage is the mirror image of the one below), and ring ``k`` has
    ``sides`` ring strings; ring 0 is pinned. ``3 sides n_stages`` members,
    ``3 sides n_stages`` free coordinates. ``free=True``: no supports, and ring 0 has its
    ring strings too (``3 sides n_stages + sides`` members, six rigid-body modes).

    Equilibrium (derived in docs/general.md): with force density ``q`` in the vertical strings
    and ``-q`` in the bars, a top-ring node is balanced along the axis and tangentially
    when the twist is ``alpha``, and radially when its ring strings carry
    ``-q cos(alpha) / (1 - cos(2 pi / sides))``; an inner ring, shared by two mirrored
    stages, carries twice that. ``q`` gives the vertical strings the strain ``prestrain``;
    rest lengths ``l0 = EA l / (EA + t)`` make the drawing the exact equilibrium, stable
    (prestress-stable, by the tests' eigenvalues) up to the rounding of very tall towers
    (docs/general.md). Strings have axial stiffness ``EA`` [N], bars ``bar_EA`` (default
    ``EA``). ``prestrain = 0`` gives the unstressed tower, an unstiffened mechanism.
    """
    if int(n_stages) < 1:
        raise StructureError(f"n_stages must be >= 1, got {n_stages!r}")
    if int(sides) < 3:
        raise StructureError(f"sides must be >= 3, got {sides!r}")
    if not prestrain >= 0:
        raise StructureError(f"prestrain must be >= 0, got {prestrain!r}")
    n, p = int(n_stages), int(sides)
    bar_ea = EA if bar_EA is None else float(bar_EA)
    alpha = np.pi / 2 + np.pi / p
    ring = np.arange(n + 1)
    angle = 2 * np.pi * np.arange(p)[None, :] / p + alpha * (ring % 2)[:, None]
    nodes = np.stack([radius * np.cos(angle), radius * np.sin(angle),
                      np.broadcast_to(stage_height * ring[:, None], angle.shape)], axis=-1).reshape(-1, 3)
    i = np.arange(p)
    k = np.arange(1, n + 1)[:, None]
    low, high = p * (k - 1), p * k                                   # first node of each ring
    odd = (k % 2 == 1)
    bars = np.stack(np.broadcast_arrays(low + i, high + i), axis=-1)
    vertical = np.stack(np.broadcast_arrays(low + i, high + np.where(odd, (i - 1) % p, (i + 1) % p)), axis=-1)
    rings = np.stack(np.broadcast_arrays(high + i, high + (i + 1) % p), axis=-1)
    members = np.concatenate([bars, vertical, rings], axis=1).reshape(-1, 2)       # stage by stage
    if free:
        members = np.concatenate([np.c_[i, (i + 1) % p], members])                   # ring 0 first
    h = nodes[members[:, 1]] - nodes[members[:, 0]]
    length = np.linalg.norm(h, axis=1)
    c = -np.cos(alpha) / (1 - np.cos(2 * np.pi / p))
    l_vertical = length[p * (2 if free else 1)]                        # one vertical string
    q = prestrain * EA / l_vertical
    ring_q = np.where(np.arange(1, n + 1) < n, 2 * c * q, c * q)       # the top ring: one stage
    density = np.concatenate(np.broadcast_arrays(np.full((n, p), -q), np.full((n, p), q),
                                                 np.repeat(ring_q[:, None], p, axis=1)), axis=1).ravel()
    kinds = np.tile(np.repeat(np.array(["bar", "string", "string"]), p), n)
    if free:
        density = np.concatenate([np.full(p, c * q), density])
        kinds = np.concatenate([np.full(p, "string"), kinds])
    ea = np.where(kinds == "bar", bar_ea, EA)
    t = density * length
    pinned = np.zeros((n + 1) * p, dtype=bool)
    pinned[:p] = not free
    return Structure.from_arrays(
        nodes, members, EA=ea, rest_lengths=ea * length / (ea + t), kinds=kinds.tolist(), pinned=pinned,
        name=f"prism tower ({n} stages of {p}-prisms, prestrain {prestrain:g})")


def prism_grid(rows: int, columns: int, *, radius: float = 1.0, height: float = 1.0, spacing: float = 2.0,
               prestrain: float = 0.01, EA: float = PAPER_EA, bar_EA: float | None = None) -> Structure:
    """A ``rows`` x ``columns`` grid of 4-prisms standing on the ground, their tops tied together.

    Unit ``(a, b)`` stands at ``(a spacing, b spacing, 0)``: a square of four pinned feet
    on a circle of ``radius`` at angles ``90 i`` degrees, a free top square at ``height``
    turned by ``alpha = 135`` degrees, four bars (foot ``i`` to top ``i``), four vertical
    strings (foot ``i`` to top ``i - 1``) and four top strings: the prism of
    :func:`prism_tower` with one stage, in the same prestressed equilibrium (vertical strings
    at strain ``prestrain``). Neighbouring tops are joined by two unstressed strings each
    (rest length = drawn length): the two nearest corners of unit ``(a, b)`` and unit
    ``(a + 1, b)``, likewise towards ``(a, b + 1)``. ``16 rows columns - 2 (rows + columns)``
    members, ``12 rows columns`` free coordinates; the drawing is the equilibrium, stable,
    and every unit stays anchored to the ground, so the smallest stiffness eigenvalue does
    not fall with the size of the grid (unlike a tall tower's).
    """
    if int(rows) < 1 or int(columns) < 1:
        raise StructureError(f"rows and columns must be >= 1, got {rows!r} and {columns!r}")
    if not prestrain >= 0:
        raise StructureError(f"prestrain must be >= 0, got {prestrain!r}")
    nr, nc, p = int(rows), int(columns), 4
    unit = prism_tower(1, sides=p, radius=radius, stage_height=height, prestrain=prestrain, EA=EA,
                       bar_EA=bar_EA)
    centre = spacing * np.stack(np.meshgrid(np.arange(nr), np.arange(nc), indexing="ij"), axis=-1).reshape(-1, 2)
    units = len(centre)
    shift = np.c_[centre, np.zeros(units)]
    nodes = (unit.nodes[None, :, :] + shift[:, None, :]).reshape(-1, 3)      # 8 nodes per unit
    base = 2 * p * np.arange(units)
    own = (unit.members[None, :, :] + base[:, None, None]).reshape(-1, 2)
    # top corner j of a unit sits at angle 90 j + 135 deg: 0 upper left, 1 lower left,
    # 2 lower right, 3 upper right (x right, y up); +x neighbours tie 3-0 and 2-1, +y 0-1 and 3-2
    index = np.arange(units).reshape(nr, nc)
    top = p + base
    right = (index[:-1, :].ravel(), index[1:, :].ravel())
    up = (index[:, :-1].ravel(), index[:, 1:].ravel())
    ties = np.concatenate([np.c_[top[right[0]] + 3, top[right[1]] + 0], np.c_[top[right[0]] + 2, top[right[1]] + 1],
                           np.c_[top[up[0]] + 0, top[up[1]] + 1], np.c_[top[up[0]] + 3, top[up[1]] + 2]])
    members = np.concatenate([own, ties])
    ea = np.concatenate([np.tile(unit.EA, units), np.full(len(ties), float(EA))])
    tie_lengths = np.linalg.norm(nodes[ties[:, 1]] - nodes[ties[:, 0]], axis=1)
    rest = np.concatenate([np.tile(unit.rest_lengths, units), tie_lengths])
    kinds = list(unit.member_kinds) * units + ["string"] * len(ties)
    pinned = np.tile(unit.pinned.any(axis=1), units)
    return Structure.from_arrays(
        nodes, members, EA=ea, rest_lengths=rest, kinds=kinds, pinned=pinned,
        name=f"prism grid ({nr} x {nc} 4-prisms, prestrain {prestrain:g})")


# --------------------------------------------------------------------------- spine
def tensegrity_spine(n_vertebrae: int = 10, *, shape: str = "straight", reach: float = 0.1,
                     leg_height: float = 0.1, spacing: float = 0.05, diagonal_ratio: float = 0.9,
                     side_ratio: float = 0.9, bend_ratio: float = 0.6,
                     s_range: tuple[float, float] = (0.5, 1.1),
                     fixed_base: bool = True, perturbation: float = 0.0, seed: int = 0,
                     EA: float = PAPER_EA) -> Structure:
    """Tensegrity spine (Sect. 5.2.5): rigid tetrahedral vertebrae stacked along z.

    Vertebra ``i`` (centre at z = ``i * spacing``) has a centre node, two lower legs
    ``(+-reach, 0, -leg_height)`` and two upper legs ``(0, +-reach, +leg_height)``. Between
    consecutive vertebrae: four vertical side strings (each leg to the same leg above:
    groups ``+x``, ``-x``, ``+y``, ``-y``) and four diagonal strings (upper legs of ``i``
    to lower legs of ``i + 1``; ``spacing < 2 leg_height`` so they push the vertebrae
    apart against the side strings). Rest lengths (times the drawn lengths): diagonals
    ``diagonal_ratio``; side strings ``side_ratio``, except

    - ``shape="C"``: group ``+x`` at ``bend_ratio`` (paper: 0.6) -- bends into a C;
    - ``shape="S"``: groups ``+x`` and ``-x`` vary sinusoidally over ``s_range`` along the
      spine with opposite phase (paper: 0.5 to 1.1) -- bends into an S;
    - ``shape="straight"``: all side strings at ``side_ratio``.

    ``perturbation`` adds uniform noise of that amplitude (seeded) to every ratio, for
    benchmarks. ``fixed_base`` fixes the lowest vertebra.
    """
    if n_vertebrae < 2:
        raise StructureError(f"n_vertebrae must be >= 2, got {n_vertebrae!r}")
    if shape not in ("straight", "C", "S"):
        raise StructureError(f"shape must be 'straight', 'C' or 'S', got {shape!r}")
    n = int(n_vertebrae)
    local = np.array([[0, 0, 0], [reach, 0, -leg_height], [-reach, 0, -leg_height],
                      [0, reach, leg_height], [0, -reach, leg_height]], dtype=float)
    nodes = (local[None, :, :] + np.c_[np.zeros((n, 2)), spacing * np.arange(n)][:, None, :]).reshape(-1, 3)
    leg = ["c", "xp", "xm", "yp", "ym"]
    node_names = [f"v{i}{leg[j]}" for i in range(n) for j in range(5)]
    def idx(i: int, j: int) -> int:
        return 5 * i + j

    members: list[tuple[int, int]] = []
    names: list[str] = []
    ratios: list[float] = []
    joints = np.arange(n - 1)
    phase = 2 * np.pi * (joints + 0.5) / (n - 1)
    lo, hi = s_range
    mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo)
    for i in map(int, joints):
        side = {1: side_ratio, 2: side_ratio, 3: side_ratio, 4: side_ratio}
        if shape == "C":
            side[1] = bend_ratio
        elif shape == "S":
            side[1] = mid + amp * np.sin(phase[i])
            side[2] = mid - amp * np.sin(phase[i])
        for j in (1, 2, 3, 4):
            members.append((idx(i, j), idx(i + 1, j)))
            names.append(f"side{leg[j]}_{i}")
            ratios.append(side[j])
        for j in (3, 4):
            for k in (1, 2):
                members.append((idx(i, j), idx(i + 1, k)))
                names.append(f"diag{leg[j]}{leg[k]}_{i}")
                ratios.append(diagonal_ratio)
    ratio = np.array(ratios)
    if perturbation:
        ratio = ratio + np.random.default_rng(seed).uniform(-perturbation, perturbation, ratio.size)
    bodies = [RigidBody(f"vertebra{i}", tuple(range(5 * i, 5 * i + 5)), fixed=(fixed_base and i == 0))
              for i in range(n)]
    return Structure.from_arrays(
        nodes, np.array(members), EA=EA, rest_length_ratio=ratio, kinds="string",
        node_names=node_names, member_names=names, bodies=bodies,
        name=f"tensegrity spine ({n} vertebrae, {shape})")
