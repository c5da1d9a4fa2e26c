"""The workspace of node D for the full actuator range, in closed form.

With ``0 <= rho1 <= L``, ``rho2 >= 0``, ``rho1 + rho2 <= 2L`` every pair ``(rho1, beta)`` in
``[0, L] x [0, pi/2]`` is an equilibrium for exactly one ``rho2`` (beta decreases strictly
with rho2 from pi/2 on the fold line ``(2 k3 + k2) rho2 = k2 rho1`` to 0 on ``rho1 + rho2 = 2L``;
docs/class2.md), so the reachable set of D = B + L (cos beta, sin beta) is::

    W = {(x, y) : 0 <= y <= L,  0 <= x - sqrt(L^2 - y^2) <= L},

bounded by the quarter circle of radius L about A, the top segment y = L (0 <= x <= L),
the quarter circle of radius L about (L, 0), and the bottom segment y = 0 (L <= x <= 2L).
Its area is ``L^2``. The equilibria with beta > pi/2 (``delta1 = +1``) lie inside W, so
W is also the set reachable within the paper's range. Lengths in metres.
"""

from __future__ import annotations

import math


def in_full_workspace(x: float, y: float, L: float, tol: float = 0.0) -> bool:
    """Whether D = (x, y) lies in W (closed set, grown by ``tol`` metres in each test)."""
    if not (-tol <= y <= L + tol):
        return False
    r1 = x - math.sqrt(max(0.0, (L - y) * (L + y)))
    return -tol <= r1 <= L + tol


def _to_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    vx, vy = bx - ax, by - ay
    t = min(1.0, max(0.0, ((px - ax) * vx + (py - ay) * vy) / (vx * vx + vy * vy)))
    return math.hypot(px - ax - t * vx, py - ay - t * vy)


def _to_quarter_arc(px: float, py: float, cx: float, L: float) -> float:
    """Distance to the arc of radius L about (cx, 0) over angles [0, pi/2]."""
    dx, dy = px - cx, py
    if dx >= 0.0 and dy >= 0.0:
        return abs(math.hypot(dx, dy) - L)
    return min(math.hypot(dx - L, dy), math.hypot(dx, dy - L))


def distance_to_full_workspace(x: float, y: float, L: float) -> float:
    """Signed distance [m] from D = (x, y) to the boundary of W: > 0 outside, <= 0 inside."""
    d = min(
        _to_quarter_arc(x, y, 0.0, L),
        _to_segment(x, y, 0.0, L, L, L),
        _to_quarter_arc(x, y, L, L),
        _to_segment(x, y, L, 0.0, 2.0 * L, 0.0),
    )
    return -d if in_full_workspace(x, y, L) else d
