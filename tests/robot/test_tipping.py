"""The quasi-static rolling derivation: the shipped 6-bar gait is the derivation's output, and
its first step is checked with the general statics directly (supports, gravity, the floor's
reactions summed here from member forces), against the closed-form margin of the regular
icosahedron."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensegrity_core.general import form_find, member_forces
from tensegrity_core.general.writing import dump_description
from tensegrity_core.robot import tipping
from tensegrity_core.robot.gait import GAITS_DIR, gait_from_dict, gait_from_file, gait_names, gait_to_dict
from tensegrity_core.robot.loading import load_robot
from tensegrity_core.robot.statics import rest_shape


@pytest.fixture(scope="module")
def six_bar():
    return load_robot("six_bar")


@pytest.fixture(scope="module")
def first_step(six_bar):
    """The shipped gait's first step: its move shared among the cables (``GAIT_SPREAD``)."""
    return tipping.tipping_steps(six_bar, 1, spread=tipping.GAIT_SPREAD)[0]


def test_the_shipped_gait_begins_with_the_derived_step(six_bar, first_step):
    assert gait_names() == ["six_bar_roll"]
    gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml")
    act = six_bar.cables.actuated
    assert gait.cables == tuple(six_bar.cables.names[j] for j in act)
    rows = np.asarray(gait.rest_lengths)
    np.testing.assert_allclose(rows[0], six_bar.cables.rest_length[act])
    expected = six_bar.cables.rest_length[act].copy()
    for j, r in zip(first_step.cables, first_step.rest_lengths):
        expected[int(np.flatnonzero(act == j)[0])] = r
    np.testing.assert_allclose(rows[1], expected, atol=1e-6)
    lo, hi = six_bar.motors.range.T
    assert np.all(rows >= lo - 1e-12) and np.all(rows <= hi + 1e-12)
    # each move is within the motors' slew limit
    speed = np.abs(np.diff(rows, axis=0)) / np.diff(gait.times)[:, None]
    assert speed.max() <= six_bar.motors.max_speed.min() * (1 + 1e-3)


def test_the_shipped_gait_file_round_trips():
    path = GAITS_DIR / "six_bar_roll.yaml"
    gait = gait_from_file(path)
    assert gait_from_dict(gait_to_dict(gait)) == gait
    body = "\n".join(line for line in path.read_text().splitlines() if not line.startswith("#")) + "\n"
    assert body == dump_description(gait_to_dict(gait))


def _supported(robot, X, face, rest):
    """The robot on ``face`` of its rest shape ``X`` under gravity, held at a (x y z), b (y z),
    c (z): its equilibrium, the floor's vertical reaction on c and the centre of mass's
    distance inside the edge ab, all from the general statics."""
    P = tipping.place_on_face(X, face, 0.05)
    a, b, c = face
    if P[c, 1] < 0:
        P = P * [1.0, -1.0, 1.0]
    pinned = np.zeros((robot.n_nodes, 3), dtype=bool)
    pinned[a] = True
    pinned[b, 1:] = True
    pinned[c, 2] = True
    s = robot.structure(rest, nodes=P, pinned=pinned, gravity=False).replace(gravity=robot.gravity)
    r = form_find(s)
    assert r.success and r.stable
    Y = r.nodes
    t = member_forces(s, Y)
    force_z = s.external_forces[c, 2]                          # half of its rod's weight
    for i, (p, q) in enumerate(s.members):
        if c in (p, q):
            other = q if p == c else p
            force_z += t[i] * (Y[other, 2] - Y[c, 2]) / np.linalg.norm(Y[other] - Y[c])
    m = robot.lumped_masses()
    return Y, -force_z, float(m @ Y[:, 1] / m.sum())


def test_the_first_step_tips_the_six_bar_by_the_general_statics(six_bar, first_step):
    X = rest_shape(six_bar).nodes
    nominal = six_bar.cables.rest_length.copy()
    Y, reaction, margin = _supported(six_bar, X, first_step.face, nominal)
    # a closed face is an equilateral triangle of side sqrt(6) L / 4: the centre of mass sits
    # above its centre, the inradius side / (2 sqrt 3) = 0.3005 m inside each edge (less the
    # sag under gravity, below a millimetre)
    inradius = math.sqrt(6) * 1.7 / 4 / (2 * math.sqrt(3))
    assert 0 < inradius - margin < 1e-3
    assert abs(margin - first_step.margin) < 1e-9 and reaction > 0
    rest = nominal.copy()
    rest[list(first_step.cables)] = first_step.rest_lengths
    Y, reaction, margin = _supported(six_bar, X, first_step.face, rest)
    assert reaction < 0 and margin < 0                         # c would have to pull: it tips
    assert abs(margin - first_step.margin_after) < 1e-6
    caps = six_bar.rods.ends.ravel()
    assert Y[caps, 2].min() >= 0.05 - 1e-6                     # no cap went into the floor


def test_a_spread_move_tips_the_six_bar_with_more_cables_each_moved_less(six_bar, first_step):
    """Off the closed face it starts on, the fewest cables (spread 1) and the shipped gait's
    spread both tip the 6-bar by the general statics; the spread move's longest travel, the
    time it takes at the motors' slew limit, is shorter."""
    X = rest_shape(six_bar).nodes
    nominal = six_bar.cables.rest_length
    fewest = tipping.tipping_step(six_bar, X, first_step.face, nominal)
    for cables, rest in ((fewest[0], fewest[1]), (first_step.cables, first_step.rest_lengths)):
        moved = nominal.copy()
        moved[list(cables)] = rest
        _, reaction, margin = _supported(six_bar, X, first_step.face, moved)
        assert reaction < 0 and margin < 0
    assert set(fewest[0]) < set(first_step.cables)
    travel = [np.abs(np.asarray(rest) - nominal[list(cables)]).max() for cables, rest in
              ((fewest[0], fewest[1]), (first_step.cables, first_step.rest_lengths))]
    assert travel[1] < travel[0]
    with pytest.raises(ValueError, match="spread must be at least 1 .* got 0.5"):
        tipping.tipping_step(six_bar, X, first_step.face, nominal, spread=0.5)


def test_place_on_face_puts_the_face_on_the_floor_and_the_rest_above():
    robot = load_robot("six_bar")
    X = rest_shape(robot).nodes
    for face in tipping.hull_faces(X):
        P = tipping.place_on_face(X, face, 0.05)
        np.testing.assert_allclose(P[list(face), 2], 0.05, atol=1e-12)
        assert np.delete(P[:, 2], list(face)).min() > 0.05
        assert abs(P[face[0], 0]) < 1e-12 and abs(P[face[1], 1]) < 1e-12 and P[face[1], 0] > 0
