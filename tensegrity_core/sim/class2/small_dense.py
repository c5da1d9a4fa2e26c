"""Dense linear algebra for systems of size <= 4 in pure Python (lists of floats).

The quasi-static path follower solves thousands of 1 x 1 to 4 x 4 systems, one at a time;
a numpy call costs several microseconds of overhead each, these a fraction of that.
"""

from __future__ import annotations

from collections.abc import Sequence
from operator import mul

#: A small matrix as its rows.
Matrix = Sequence[Sequence[float]]
Vector = Sequence[float]


def solve_small(A: Matrix, b: Vector) -> list[float]:
    """Solve ``A x = b`` (``A`` a list of rows, ``b`` a list) by Gaussian elimination with
    partial pivoting. Raises :class:`ZeroDivisionError` when a pivot is exactly zero."""
    n = len(b)
    M = [list(row) + [b[i]] for i, row in enumerate(A)]
    for c in range(n):
        p, big = c, abs(M[c][c])
        for r in range(c + 1, n):
            a = abs(M[r][c])
            if a > big:
                p, big = r, a
        if big == 0.0:
            raise ZeroDivisionError("singular matrix")
        if p != c:
            M[c], M[p] = M[p], M[c]
        pivot_row = M[c]
        inv = 1.0 / pivot_row[c]
        for r in range(c + 1, n):
            row = M[r]
            f = row[c] * inv
            if f != 0.0:
                for j in range(c + 1, n + 1):
                    row[j] -= f * pivot_row[j]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        row = M[r]
        acc = row[n]
        for j in range(r + 1, n):
            acc -= row[j] * x[j]
        x[r] = acc / row[r]
    return x


def principal_det(K: Matrix, idx: Sequence[int]) -> float:
    """Determinant of the principal submatrix ``K[idx][:, idx]`` (``K`` 3 x 3 lists, ``idx``
    1 to 3 sorted indices)."""
    if len(idx) == 1:
        return K[idx[0]][idx[0]]
    if len(idx) == 2:
        a, b = idx
        return K[a][a] * K[b][b] - K[a][b] * K[b][a]
    return (K[0][0] * (K[1][1] * K[2][2] - K[1][2] * K[2][1]) - K[0][1] * (K[1][0] * K[2][2] - K[1][2] * K[2][0])
            + K[0][2] * (K[1][0] * K[2][1] - K[1][1] * K[2][0]))


def positive_definite(K: Matrix, idx: Sequence[int]) -> bool:
    """Sylvester's criterion on the symmetric principal submatrix ``K[idx][:, idx]`` (size <= 3)."""
    a = idx[0]
    if K[a][a] <= 0.0:
        return False
    if len(idx) == 1:
        return True
    if principal_det(K, idx[:2]) <= 0.0:
        return False
    return len(idx) == 2 or principal_det(K, idx) > 0.0



#: The adjugate is used while ``|det|`` exceeds this times the largest diagonal entry to the
#: power of the size (a condition number below ~1e6: errors below ~1e-10); nearer to singular,
#: pivoted elimination.
WELL_CONDITIONED = 1e-6


def _adjugate(K: Matrix, idx: Sequence[int]) -> tuple[Matrix, float] | None:
    """``(rows of adj(K_FF), det(K_FF))`` of the symmetric principal submatrix for 2 or 3
    indices, or ``None`` near singular (:data:`WELL_CONDITIONED`)."""
    if len(idx) == 3:
        (a, b, c), (_, d, e), (_, _, f) = K
        A00, A01, A02 = d * f - e * e, c * e - b * f, b * e - c * d
        A11, A12, A22 = a * f - c * c, b * c - a * e, a * d - b * b
        det = a * A00 + b * A01 + c * A02
        if abs(det) > WELL_CONDITIONED * max(abs(a), abs(d), abs(f)) ** 3:
            return ((A00, A01, A02), (A01, A11, A12), (A02, A12, A22)), det
        return None
    i, j = idx
    a, b, d = K[i][i], K[i][j], K[j][j]
    det = a * d - b * b
    if abs(det) > WELL_CONDITIONED * max(abs(a), abs(d)) ** 2:
        return ((d, -b), (-b, a)), det
    return None


def _times(rows: Matrix, x: Vector) -> list[float]:
    """The matrix ``rows`` (2 x 2 or 3 x 3) times the vector ``x``."""
    if len(x) == 3:
        (a, b, c), (d, e, f), (g, h, i) = rows
        x0, x1, x2 = x
        return [a * x0 + b * x1 + c * x2, d * x0 + e * x1 + f * x2, g * x0 + h * x1 + i * x2]
    (a, b), (c, d) = rows
    x0, x1 = x
    return [a * x0 + b * x1, c * x0 + d * x1]


def solve_symmetric(K: Matrix, idx: Sequence[int], r: Vector) -> list[float]:
    """Solve ``K[idx][:, idx] x = r`` for symmetric ``K`` (3 x 3 lists, ``idx`` 1 to 3 sorted
    indices, ``r`` a list over ``idx``) with the explicit adjugate -- a few multiplications
    where elimination loops cost microseconds -- or :func:`solve_small` near singular.
    Raises :class:`ZeroDivisionError` when singular."""
    if len(idx) == 1:
        k = K[idx[0]][idx[0]]
        if k != 0.0:
            return [r[0] / k]
    else:
        found = _adjugate(K, idx)
        if found is not None:
            adj, det = found
            return [x / det for x in _times(adj, r)]
    return solve_small([[K[a][b] for b in idx] for a in idx], list(r))


def solve_bordered(K: Matrix, idx: Sequence[int], g: Vector, w: Vector, wt: float, r: Vector,
                   s: float) -> list[float]:
    """Solve ``[[K_FF, g], [w, wt]] [x; y] = [r; s]`` (``K_FF = K[idx][:, idx]`` symmetric,
    ``g, w, r`` lists over ``idx``) by block elimination with the adjugate of ``K_FF``:
    ``y = (s det - w adj r) / (wt det - w adj g)``, ``x = (adj r - adj g y) / det``; near a
    singular ``K_FF`` (limit and branch points, where the bordered matrix stays regular) by
    :func:`solve_small` on the whole matrix; a 2 x 2 bordered system by Cramer's rule. Returns
    ``x + [y]``; raises :class:`ZeroDivisionError` when singular."""
    if len(idx) == 1:
        k = K[idx[0]][idx[0]]
        det = k * wt - g[0] * w[0]
        if det != 0.0:
            return [(r[0] * wt - g[0] * s) / det, (k * s - w[0] * r[0]) / det]
    else:
        found = _adjugate(K, idx)
        if found is not None:
            adj, det = found
            p, h = _times(adj, r), _times(adj, g)
            den = wt * det - sum(map(mul, w, h))
            if den != 0.0:
                y = (s * det - sum(map(mul, w, p))) / den
                return [(a - b * y) / det for a, b in zip(p, h)] + [y]
    A = [[K[a][b] for b in idx] + [g[j]] for j, a in enumerate(idx)]
    A.append(list(w) + [wt])
    return solve_small(A, list(r) + [s])
