"""Which face of its hull a robot rests on, from the contact state: the faces a rolling robot visits.

A robot rests on a *face* when a set of at least three end caps touches the floor; the
contact state (per cap: touching or not, the ``cap_contact`` sensor reading) over time gives
the sequence of faces. A set counts as a face when it holds for at least ``hold`` seconds
(50 ms by default: a cap that grazes the floor for a sample while the robot tips makes no
face); consecutive repeats merge, and :func:`faces_rolled` counts a return to a face
visited before (a rock back) as no new face. :func:`progress_faces` is the robot's net path:
the faces with every excursion onto a face and back removed, so a rock onto a face and back
counts nothing; ``len(progress_faces(...)) - 1`` faces of progress. :func:`faces_touched` is the strict count: every
hull face whose caps all touched at one sample, however briefly (a robot that rolls through a
face without resting on it has still crossed its edges), and :func:`edge_by_edge` whether the
faces touched follow each other over one shared edge each.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

Face = TypeVar("Face", bound=Hashable)


def faces_visited(times: Sequence[float] | NDArray[np.float64], contact: NDArray[np.bool_],
                  hold: float = 0.05) -> list[tuple[float, frozenset[int]]]:
    """``[(t, caps), ...]``: each face (a set of at least three touching caps, indices into
    the caps) the robot rests on for at least ``hold`` [s], with the time [s] it first
    touched, in order; ``contact`` (N, caps) the touching flags at ``times`` (N,) [s]. A set
    lasts from its first sample to the next set's first sample."""
    t = np.asarray(times, dtype=float)
    rows = np.asarray(contact, dtype=bool)
    runs: list[tuple[float, frozenset[int]]] = []           # (first sample's time, caps)
    for i, row in enumerate(rows):
        caps = frozenset(np.flatnonzero(row).tolist())
        if not runs or runs[-1][1] != caps:
            runs.append((float(t[i]), caps))
    ends = [start for start, _ in runs[1:]] + [float(t[-1]) if len(t) else 0.0]
    faces: list[tuple[float, frozenset[int]]] = []
    for (start, caps), end in zip(runs, ends):
        if len(caps) >= 3 and end - start >= hold * (1 - 1e-9) and (not faces or faces[-1][1] != caps):
            faces.append((start, caps))
    return faces


def faces_rolled(faces: Sequence[tuple[float, frozenset[int]]]) -> int:
    """How many faces a robot rolled over: the faces it reached that it had not rested on
    before (``faces`` from :func:`faces_visited`; the first is where it started)."""
    seen: set[frozenset[int]] = set()
    new = 0
    for _, caps in faces:
        new += caps not in seen
        seen.add(caps)
    return max(new - 1, 0)


def progress_faces(faces: Sequence[Face]) -> list[Face]:
    """The robot's net path over ``faces`` (the caps of the faces it rested on, in order, as
    :func:`faces_visited` gives them): every return to the face before the last removed with
    the excursion (``A B A`` -> ``A``, so ``A B C B A`` -> ``A``); the first is where it
    started, each later one a face of progress. Any labels of faces do (caps' indices or
    names)."""
    path: list[Face] = []
    for face in faces:
        if path and path[-1] == face:
            continue
        if len(path) >= 2 and path[-2] == face:
            path.pop()
        else:
            path.append(face)
    return path


def faces_touched(touching: Sequence[Sequence[int]] | NDArray[np.int64],
                  faces: Sequence[tuple[int, int, int]]) -> list[frozenset[int]]:
    """The hull ``faces`` (node indices) whose three caps all touched the floor at one of the
    samples ``touching`` (per sample the touching caps' node indices), in the order first
    touched; ``len(...) - 1`` is how many faces the robot reached beyond the first."""
    out: list[frozenset[int]] = []
    for row in touching:
        now = {int(i) for i in row}
        out += [frozenset(f) for f in faces if now.issuperset(f) and frozenset(f) not in out]
    return out


def edge_by_edge(touching: Sequence[Sequence[int]] | NDArray[np.int64],
                 faces: Sequence[tuple[int, int, int]]) -> bool:
    """Whether the hull ``faces`` whose three caps touch, in the order touched (``touching``:
    per sample the touching caps' node indices), each share an edge with the one before: the
    robot crossed one edge at a time, never a face on two caps without its third touching."""
    seq: list[frozenset[int]] = []
    for row in touching:
        now = {int(i) for i in row}
        for f in faces:
            if now.issuperset(f) and (not seq or seq[-1] != frozenset(f)):
                seq.append(frozenset(f))
    return all(len(p & q) == 2 for p, q in zip(seq, seq[1:]))
