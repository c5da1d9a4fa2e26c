"""Dense linear algebra for systems of size <= 4 in pure Python (lists of floats).

The quasi-static path follower solves thousands of 1 x 1 to 4 x 4 systems, one at a time;
a numpy call costs several microseconds of overhead each, these a fraction of that.
"""

from __future__ import annotations


def solve_small(A, b) -> list:
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


def principal_det(K, idx) -> float:
    """Determinant of the principal submatrix ``K[idx][:, idx]`` (``K`` 3 x 3 lists, ``idx``
    1 to 3 sorted indices)."""
    if len(idx) == 1:
        return K[idx[0]][idx[0]]
    if len(idx) == 2:
        a, b = idx
        return K[a][a] * K[b][b] - K[a][b] * K[b][a]
    return (K[0][0] * (K[1][1] * K[2][2] - K[1][2] * K[2][1]) - K[0][1] * (K[1][0] * K[2][2] - K[1][2] * K[2][0])
            + K[0][2] * (K[1][0] * K[2][1] - K[1][1] * K[2][0]))


def positive_definite(K, idx) -> bool:
    """Sylvester's criterion on the symmetric principal submatrix ``K[idx][:, idx]`` (size <= 3)."""
    a = idx[0]
    if K[a][a] <= 0.0:
        return False
    if len(idx) == 1:
        return True
    if principal_det(K, idx[:2]) <= 0.0:
        return False
    return len(idx) == 2 or principal_det(K, idx) > 0.0
