"""Geometry of the drawing: a unit cylinder along +Z placed on each segment, the poses of rigid
point sets, the floor's grid lines."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.general.rotation import best_fit_rotations

FloatArray = NDArray[np.float64]


def z_to(directions: FloatArray) -> FloatArray:
    """Unit quaternions ``(w, x, y, z)`` (k, 4) rotating +Z onto each of ``directions`` (k, 3)
    (any length > 0): about the axis ``Z x d`` by the angle ``atan2(|Z x d|, Z . d)``
    (half-angle form: no cancellation near -Z, where the axis is taken as X)."""
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    axis = np.stack([-d[:, 1], d[:, 0], np.zeros(len(d))], axis=1)
    sin = np.linalg.norm(axis, axis=1)
    half = 0.5 * np.arctan2(sin, d[:, 2])
    axis = np.where(sin[:, None] > 0, axis / np.maximum(sin, 1e-300)[:, None], [1.0, 0.0, 0.0])
    return np.hstack([np.cos(half)[:, None], axis * np.sin(half)[:, None]])


def segment_poses(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Mid-points (k, 3), orientations ``(w, x, y, z)`` (k, 4) and lengths (k,) [m] of the
    segments from ``a`` to ``b`` (k, 3); a segment of zero length keeps +Z and length 0."""
    a = np.asarray(a, dtype=float).reshape(-1, 3)
    b = np.asarray(b, dtype=float).reshape(-1, 3)
    v = b - a
    lengths = np.linalg.norm(v, axis=1)
    v[lengths <= 0.0] = (0.0, 0.0, 1.0)
    return 0.5 * (a + b), z_to(v), lengths


def rigid_poses(template: FloatArray, points: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Positions (b, 3) [m] and orientations ``(w, x, y, z)`` (b, 4) that carry ``template``
    (k, 3), centred at its mean, onto each of ``points`` (b, k, 3): ``points[j, i] = p_j +
    R(q_j) (template[i] - mean(template))`` for a rigid motion, its least-squares fit otherwise
    (Kabsch: the rotation from the SVD of the points' cross-covariance, a reflection ruled out).
    ``p_j`` is the mean of ``points[j]``. Points on one line leave the turn about that line
    undetermined (any one is returned); points not all finite give a position that is not
    either, and no turn."""
    t = np.asarray(template, dtype=float)
    q = np.asarray(points, dtype=float).reshape(-1, *t.shape)
    with np.errstate(invalid="ignore"):                       # inf - inf of a diverged state: NaN, no warning
        centre = q.mean(axis=1)
        moved = q - centre[:, None, :]
    t = t - t.mean(axis=0)
    moved[~np.isfinite(moved).all(axis=(1, 2))] = t             # such a state: no turn, its position not finite
    rot = best_fit_rotations(t, moved)
    quat = Rotation.from_matrix(rot).as_quat(canonical=True, scalar_first=True)
    return centre, quat


def unit_cylinder(sections: int = 16) -> tuple[NDArray[np.float32], NDArray[np.uint32]]:
    """Vertices (2 sections + 2, 3) and outward-facing triangles (4 sections, 3) of a closed
    cylinder of radius 1 and height 1 along Z, centred at the origin: a ring of ``sections``
    vertices at z = -1/2 and at z = +1/2, and the centres of its two end caps.

    Written here rather than taken from trimesh (``trimesh.creation.cylinder``): the view
    draws one such mesh, and importing trimesh costs more of the view's start than the rest
    of its drawing code (docs/design/view.md)."""
    a = 2 * np.pi * np.arange(sections) / sections
    ring = np.stack([np.cos(a), np.sin(a)], axis=1)
    vertices = np.vstack([np.hstack([ring, np.full((sections, 1), -0.5)]), np.hstack([ring, np.full((sections, 1), 0.5)]),
                          [[0.0, 0.0, -0.5], [0.0, 0.0, 0.5]]]).astype(np.float32)
    i = np.arange(sections)
    j = (i + 1) % sections
    bottom, top = 2 * sections, 2 * sections + 1
    faces = np.vstack([np.stack([i, j, sections + j], axis=1), np.stack([i, sections + j, sections + i], axis=1),
                       np.stack([np.full(sections, bottom), j, i], axis=1),
                       np.stack([np.full(sections, top), sections + i, sections + j], axis=1)])
    return vertices, faces.astype(np.uint32)


def grid_lines(half_width: float, cells: int, every: int) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """The lines of a square grid on the plane z = 0 centred at the origin: ``cells`` cells
    across its width ``2 half_width`` [m], lines parallel to X, then to Y, ``cells + 1`` of
    each, as segments (2 (cells + 1), 2, 3); and which of them are section lines (every
    ``every``-th line from the centre one)."""
    at = np.linspace(-half_width, half_width, cells + 1)
    ends = np.full(cells + 1, half_width)
    zeros = np.zeros(cells + 1)
    along_x = np.stack([np.stack([-ends, at, zeros], axis=1), np.stack([ends, at, zeros], axis=1)], axis=1)
    along_y = along_x[:, :, [1, 0, 2]]
    section = (np.arange(cells + 1) - cells // 2) % every == 0
    return np.concatenate([along_x, along_y]).astype(np.float32), np.concatenate([section, section])
