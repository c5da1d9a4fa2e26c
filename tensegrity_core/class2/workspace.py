"""Workspace of node D for given actuator limits, its boundary, and the images of the singular sets.

The admissible actuator set is the convex polygon ``P`` of the actuator plane cut out by the
limits ``rho_min <= rho_i <= rho_max`` (intersected with ``0 <= rho1 <= L`` and
``0 <= rho2 <= 2L``), by ``rho1 + rho2 <= 2L`` and, within the paper's range, by the fold line
``(2 k3 + k2) rho2 >= k2 rho1`` (beta <= pi/2). Every edge of ``P`` is a straight segment.
The map ``rho -> D`` is smooth on the interior of the configuration domain with
``det(dD/drho) = L cos(beta) dbeta/drho2`` and ``dbeta/drho2 < 0`` there (docs/class2.md), so
its only interior critical curve is the fold line. The boundary of the reachable set is
therefore contained in the images of the edges of ``P`` and of the fold line; each image
point is marked ``on_boundary`` by testing the reachable set on a small circle around it.

Membership is exact: a target is reachable iff one of its inverse-kinematics candidates is
a genuine equilibrium whose lengths lie in ``P`` (:func:`ik_array_all`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Final, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.ik_arrays import ik_array_all
from tensegrity_core.class2.kinematics import as_real, fk_array
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import DomainError

#: Tolerance (times L) for lengths on a limit of the polygon.
LIMIT_TOL: Final = 1e-12


@dataclass(frozen=True)
class Constraint:
    """Half-plane ``a rho1 + b rho2 <= c`` of the actuator plane, with its meaning."""

    a: float
    b: float
    c: float
    kind: str    # rho1_min | rho1_max | rho2_min | rho2_max | lambda1 | beta_half_pi
    label: str   # human-readable, e.g. "rho1 = 0 m (lower limit)"


@dataclass(frozen=True)
class Curve:
    """A segment of the actuator plane and its image under FK, both ordered, shape (n, 2).

    ``on_boundary[j]`` tells whether ``xy[j]`` lies on the boundary of the reachable set.
    """

    kind: str
    label: str
    rho: NDArray[np.float64]
    xy: NDArray[np.float64]
    on_boundary: NDArray[np.bool_]


#: Lower and upper limit of an actuator length [m].
Range: TypeAlias = tuple[float, float]


def actuator_ranges(params: Class2Params, rho1_range: Sequence[float] | None = None,
                    rho2_range: Sequence[float] | None = None) -> tuple[Range, Range]:
    """Validated limits ``((lo1, hi1), (lo2, hi2))`` [m], intersected with [0, L] and [0, 2L]."""
    L = params.L
    out: list[Range] = []
    for name, rng, cap in (("rho1", rho1_range, L), ("rho2", rho2_range, 2.0 * L)):
        if rng is None:
            out.append((0.0, cap))
            continue
        if len(rng) != 2:
            raise DomainError(f"{name}_range must be (min, max), got {rng!r}")
        lo, hi = as_real(f"{name}_range min", rng[0]), as_real(f"{name}_range max", rng[1])
        if lo > hi:
            raise DomainError(f"{name}_range min {lo:g} m exceeds max {hi:g} m")
        if hi < 0.0 or lo > cap:
            raise DomainError(
                f"{name}_range [{lo:g}, {hi:g}] m does not meet the admissible [0, {cap:g}] m",
                distance=max(-hi, lo - cap),
            )
        out.append((max(lo, 0.0), min(hi, cap)))
    return out[0], out[1]


def _constraints(params: Class2Params, r1: Range, r2: Range, paper_range: bool) -> list[Constraint]:
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    cons = [
        Constraint(-1.0, 0.0, -r1[0], "rho1_min", f"rho1 = {r1[0]:g} m (lower limit)"),
        Constraint(0.0, -1.0, -r2[0], "rho2_min", f"rho2 = {r2[0]:g} m (lower limit)"),
        Constraint(1.0, 0.0, r1[1], "rho1_max",
                   f"rho1 = {r1[1]:g} m (upper limit" + (", lambda2 = 0: F at A)" if r1[1] == L else ")")),
        Constraint(0.0, 1.0, r2[1], "rho2_max", f"rho2 = {r2[1]:g} m (upper limit)"),
        Constraint(1.0, 1.0, 2.0 * L, "lambda1", f"rho1 + rho2 = 2L = {2 * L:g} m (lambda1 = 0, D on the X axis)"),
    ]
    if paper_range:
        cons.append(Constraint(k2, -K, 0.0, "beta_half_pi",
                               f"{K:g} rho2 = {k2:g} rho1 (beta = pi/2, fold: det dD/drho = 0)"))
    return cons


def _clip_polygon(cons: list[Constraint], L: float) -> list[tuple[NDArray[np.float64], int]]:
    """Vertices of the polygon ``{all constraints}`` in order, each with the index of the
    constraint carrying the edge that ARRIVES at it (Sutherland-Hodgman on the 4 box sides)."""
    big = 10.0 * L
    poly = [(np.array(v, float), -1) for v in ((-big, -big), (big, -big), (big, big), (-big, big))]
    for ci, con in enumerate(cons):
        n = np.array([con.a, con.b])

        def inside(p: NDArray[np.float64], n: NDArray[np.float64] = n, c: float = con.c) -> bool:
            return bool(n @ p <= c + 1e-15 * L)

        out: list[tuple[NDArray[np.float64], int]] = []
        for k in range(len(poly)):
            (p, _), (q, lab) = poly[k - 1], poly[k]
            pin, qin = inside(p), inside(q)
            if pin and qin:
                out.append((q, lab))
            elif pin or qin:
                t = (con.c - n @ p) / (n @ (q - p))
                ipt = p + t * (q - p)
                if pin:
                    out.append((ipt, lab))
                else:
                    out.append((ipt, ci))
                    out.append((q, lab))
        dedup: list[tuple[NDArray[np.float64], int]] = []
        for v in out:
            if not dedup or np.linalg.norm(v[0] - dedup[-1][0]) > 1e-14 * L:
                dedup.append(v)
        if len(dedup) > 1 and np.linalg.norm(dedup[0][0] - dedup[-1][0]) <= 1e-14 * L:
            dedup[0] = (dedup[0][0], dedup[-1][1])
            dedup.pop()
        poly = dedup
        if not poly:
            break
    return poly


def _line_in_polygon(cons: list[Constraint], point: ArrayLike, direction: ArrayLike,
                     skip: str) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """Part of the line ``point + t direction`` inside every constraint but ``skip`` (Cyrus-Beck)."""
    p, d = np.asarray(point, float), np.asarray(direction, float)
    lo, hi = -np.inf, np.inf
    for con in cons:
        if con.kind == skip:
            continue
        nd, npt = con.a * d[0] + con.b * d[1], con.a * p[0] + con.b * p[1]
        if abs(nd) < 1e-300:
            if npt > con.c + 1e-12:
                return None
            continue
        t = (con.c - npt) / nd
        lo, hi = (max(lo, t), hi) if nd < 0 else (lo, min(hi, t))
    if not lo <= hi or not np.isfinite(lo) or not np.isfinite(hi):
        return None
    return p + lo * d, p + hi * d


def _sample(a: NDArray[np.float64], b: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """``n`` points from a to b, clustered at the ends (where the FK map has sqrt behaviour)."""
    t = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, n))
    return a[None, :] + t[:, None] * (b - a)[None, :]


@dataclass(frozen=True)
class Workspace:
    """Reachable set of node D for actuator limits (see the module docstring).

    Attributes
    ----------
    rho1_range, rho2_range : effective limits [m] after intersection with the domain.
    paper_range : whether only equilibria with beta <= pi/2 count (the paper's range).
    polygon : vertices of the admissible actuator polygon, counter-clockwise, shape (m, 2).
    edges : images of the polygon's edges, in polygon order.
    singular_curves : the singular sets inside the polygon (the lambda1, lambda2 and
        beta_half_pi lines, the folded point as a one-point curve) and their images.
    """

    params: Class2Params
    rho1_range: tuple[float, float]
    rho2_range: tuple[float, float]
    paper_range: bool
    polygon: NDArray[np.float64]
    edges: tuple[Curve, ...]
    singular_curves: tuple[Curve, ...]
    constraints: tuple[Constraint, ...] = field(repr=False)

    def contains(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
        """Whether each target D = (x, y) is reachable (broadcast boolean array)."""
        return _reachable(x, y, self.params, self.constraints, self.paper_range)

    def boundary_xy(self) -> list[NDArray[np.float64]]:
        """The boundary of the reachable set as ordered polylines (runs of on-boundary points)."""
        runs: list[NDArray[np.float64]] = []
        for curve in self.edges + tuple(c for c in self.singular_curves if c.kind == "beta_half_pi"):
            mask = curve.on_boundary
            start: int | None = None
            for j in range(len(mask) + 1):
                if j < len(mask) and mask[j]:
                    start = j if start is None else start
                elif start is not None:
                    if j - start > 1:
                        runs.append(curve.xy[start:j])
                    start = None
        return runs

    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the edge images [m]."""
        pts = np.concatenate([c.xy for c in self.edges])
        return (float(pts[:, 0].min()), float(pts[:, 0].max()), float(pts[:, 1].min()), float(pts[:, 1].max()))

    def area(self, resolution: int = 800) -> float:
        """Area of the reachable set [m^2].

        Within the paper's range the map ``(rho1, beta) -> D`` is one-to-one with Jacobian
        ``L cos(beta)``, so the area is ``int (y(rho1, rho2_min(rho1)) - y(rho1, rho2_max(rho1))) drho1``
        (beta falls as rho2 grows), integrated with :func:`scipy.integrate.quad`. With
        ``paper_range=False`` the two sheets overlap and the area is counted on a
        ``resolution`` x ``resolution`` grid of :meth:`contains` (error ~ perimeter x cell).
        """
        if self.paper_range:
            return self._area_paper()
        x0, x1, y0, y1 = self.bounds()
        xs = np.linspace(x0, x1, resolution + 1)
        ys = np.linspace(y0, y1, resolution + 1)
        xc, yc = 0.5 * (xs[1:] + xs[:-1]), 0.5 * (ys[1:] + ys[:-1])
        inside = self.contains(xc[None, :], yc[:, None])
        return float(inside.sum() * (xs[1] - xs[0]) * (ys[1] - ys[0]))

    def _rho2_interval(self, rho1: float) -> tuple[float, float] | None:
        lo, hi = -math.inf, math.inf
        for con in self.constraints:
            if con.b == 0.0:
                continue
            bound = (con.c - con.a * rho1) / con.b
            lo, hi = (max(lo, bound), hi) if con.b < 0 else (lo, min(hi, bound))
        return (lo, hi) if lo <= hi else None

    def _area_paper(self) -> float:
        from scipy import integrate

        L = self.params.L
        a1, b1 = float(self.polygon[:, 0].min()), float(self.polygon[:, 0].max())
        if b1 - a1 <= 1e-15 * L:
            return 0.0

        def height(r1: float) -> float:
            iv = self._rho2_interval(r1)
            if iv is None:
                return 0.0
            out = fk_array(np.full(2, r1), np.clip(np.array(iv), 0.0, 2.0 * L - r1), self.params)
            return float(out.y[0] - out.y[1])

        breaks = sorted({float(v) for v in self.polygon[:, 0] if a1 < v < b1})
        val, _ = integrate.quad(height, a1, b1, points=breaks or None, limit=200, epsabs=1e-13, epsrel=1e-11)
        return float(val)


def _reachable(x: ArrayLike, y: ArrayLike, params: Class2Params, cons: Sequence[Constraint],
               paper_range: bool) -> NDArray[np.bool_]:
    res = ik_array_all(x, y, params)
    ok = (res.code == 0) | ((res.code == 1) & (not paper_range))
    tol = LIMIT_TOL * params.L
    for con in cons:
        ok &= con.a * res.rho1 + con.b * res.rho2 <= con.c + tol
    reachable: NDArray[np.bool_] = ok.any(axis=-1)
    return reachable


_RING: Final = np.exp(1j * np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False))


def _image(kind: str, label: str, a: NDArray[np.float64], b: NDArray[np.float64], params: Class2Params, n: int,
           cons: Sequence[Constraint], paper_range: bool) -> Curve:
    """The curve from a to b in the actuator plane, its FK image, and which image points are
    on the boundary of the reachable set (a circle of radius 1e-6 L around them leaves it)."""
    rho = _sample(a, b, n)
    L = params.L
    rho[:, 0] = np.clip(rho[:, 0], 0.0, L)
    rho[:, 1] = np.clip(rho[:, 1], 0.0, 2.0 * L - rho[:, 0])
    fk = fk_array(rho[:, 0], rho[:, 1], params)
    xy = np.column_stack([fk.x, fk.y])
    probe = (fk.x + 1j * fk.y)[:, None] + 1e-6 * L * _RING[None, :]
    inside = _reachable(probe.real, probe.imag, params, cons, paper_range)
    return Curve(kind, label, rho, xy, ~inside.all(axis=1) & fk.valid)


def workspace(
    params: Class2Params = PAPER_PARAMS,
    rho1_range: Sequence[float] | None = None,
    rho2_range: Sequence[float] | None = None,
    *,
    paper_range: bool = True,
    n: int = 200,
) -> Workspace:
    """The reachable set of D for actuator limits [m] (default: the full ranges).

    ``paper_range=True`` counts only equilibria with beta <= pi/2 (the paper's range; for
    the full ranges both choices give the same set, docs/class2.md). ``n`` points per curve.
    Raises :class:`DomainError` for limits that leave no admissible configuration.
    """
    r1, r2 = actuator_ranges(params, rho1_range, rho2_range)
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    cons = _constraints(params, r1, r2, paper_range)
    poly = _clip_polygon(cons, L)
    if not poly:
        hint = " within the paper's range (try paper_range=False)" if paper_range else ""
        raise DomainError(
            f"no admissible configuration for rho1 in [{r1[0]:g}, {r1[1]:g}] m, rho2 in "
            f"[{r2[0]:g}, {r2[1]:g}] m with rho1 + rho2 <= 2L{hint}"
        )
    edges: list[Curve] = []
    for k in range(len(poly)):
        (p, _), (q, lab) = poly[k - 1], poly[k]
        if lab < 0 or np.linalg.norm(q - p) <= 1e-14 * L:
            continue
        edges.append(_image(cons[lab].kind, cons[lab].label, p, q, params, n, cons, paper_range))
    singular: list[Curve] = []
    for kind, label, point, direction in (
        ("lambda1", "rho1 + rho2 = 2L (lambda1 = 0)", (2.0 * L, 0.0), (-1.0, 1.0)),
        ("lambda2", "rho1 = L (lambda2 = 0)", (L, 0.0), (0.0, 1.0)),
        ("beta_half_pi", "beta = pi/2 (det dD/drho = 0, IK discriminant = 0)", (0.0, 0.0), (K, k2)),
    ):
        seg = _line_in_polygon(cons, point, direction, skip=kind)
        if seg is not None:
            singular.append(_image(kind, label, seg[0], seg[1], params, n, cons, paper_range))
    if all(con.c >= 0.0 for con in cons):
        origin = np.zeros(2)
        singular.append(_image("folded", "rho1 = rho2 = 0 (folded)", origin, origin, params, 1, cons, paper_range))
    return Workspace(params, r1, r2, paper_range, np.array([v for v, _ in poly]),
                     tuple(edges), tuple(singular), tuple(cons))
