"""The pure parts of ``tensegrity gait``: a gait as trajectory points (checked against the
core's own evaluation of the gait's laws), the 6-bar's rolling gait cut to its first faces
(the release by the derivation's rule, which reproduces the shipped file's own end), gaits
by name, and the roll summary and the rest after a gait from synthetic samples whose answers
are known by construction."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.robot.gait import GAITS_DIR, Gait, GaitError, gait_from_file
from tensegrity_ros.apps.gait_goal import HOLD_EDGE_S, first_faces, gait_named, tips, trajectory_points
from tensegrity_ros.apps.roll_summary import REST_HOLD_S, REST_SPEED, rest_time, roll_summary


def _played(points, t: float) -> np.ndarray:
    """The rest lengths a linear-interpolating controller commands ``t`` s after the start."""
    pos = np.asarray(points.positions)
    return np.array([np.interp(t, points.times, pos[:, j]) for j in range(pos.shape[1])])


def _gait(interpolation: str, **options) -> Gait:
    return Gait(name="test", cables=("a", "b"), times=(0.0, 0.5, 1.25, 2.0),
                rest_lengths=((1.0, 0.8), (0.7, 0.9), (0.6, 1.0), (1.0, 0.8)), interpolation=interpolation,
                period=options.pop("period", None), **options)


@given(t=st.floats(0.0, 20.0), start=st.sampled_from([0.0, 0.3]), scale=st.sampled_from([1.0, 0.5, 2.0]),
       cycles=st.sampled_from([1, 3]), interpolation=st.sampled_from(["linear", "previous"]))
def test_the_trajectory_plays_what_the_gaits_laws_give(t, start, scale, cycles, interpolation):
    gait = _gait(interpolation, period=2.5, cycles=cycles, time_scale=scale, start=start)
    points = trajectory_points(gait)
    assert points.times[0] == 0.0 and all(b > a for a, b in zip(points.times, points.times[1:]))
    laws = gait.laws()
    corners = np.asarray(gait.table()[0])
    if interpolation == "previous" and np.any((corners - HOLD_EDGE_S <= t) & (t < corners)):
        return                  # inside the edge before a row: the ramp of HOLD_EDGE_S
    expected = [laws[name].value_at(t, 0.0) for name in gait.cables]
    assert np.allclose(_played(points, t), expected, rtol=0, atol=1e-12)


def test_the_six_bar_gait_cut_to_its_first_faces():
    gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml")
    assert tips(gait) == 8              # the file's own description: "over 8 faces"
    assert first_faces(gait, 8) == dataclasses.replace(gait, description="the first 8 of 8 faces of six_bar_roll")
    three = first_faces(gait, 3)
    # nominal, then per tip: move, hold, release, rest
    assert three.rest_lengths == gait.rest_lengths[:13] and three.times == gait.times[:13]
    assert three.rest_lengths[-1] == gait.rest_lengths[0]
    assert tips(three) == 3
    with pytest.raises(GaitError, match=r"rolls 8 faces: faces must be in \[1, 8\], got 9"):
        first_faces(gait, 9)
    with pytest.raises(GaitError, match="not a rolling gait"):
        first_faces(gait_named("three_bar_crawl"), 1)


def test_gaits_by_name():
    roll = gait_named("six_bar_roll")
    assert tips(roll) == 8 and len(roll.cables) == 24
    crawl = gait_named("three_bar_crawl")       # the scene's inline gait with its options
    assert crawl.cables == tuple(f"td_{i}" for i in range(6))
    assert (crawl.period, crawl.cycles, crawl.start) == (4.0001, 20, 2.0)
    assert trajectory_points(crawl).duration == pytest.approx(2.0 + 20 * 4.0001)
    with pytest.raises(GaitError, match="no shipped gait or robot scene named 'six_bar_rol'.*six_bar_roll"):
        gait_named("six_bar_rol")


def test_the_roll_summary_of_a_run_known_by_construction():
    # the centre moves 1.2 m along x and 0.5 m along y: 1.3 m
    centres = [(0.0, 0.0, 0.3), (0.6, 0.2, 0.31), (1.2, 0.5, 0.3)]
    t = np.arange(0, 1.0, 0.01)
    contacts = []
    for ti in t:
        if ti < 0.3:
            contacts.append(("a", "b", "c"))          # the first face
        elif ti < 0.32:
            contacts.append(("a", "b", "c", "e"))     # a graze of 20 ms: no face
        elif ti < 0.6:
            contacts.append(("a", "b", "d"))          # rolled onto a new face
        elif ti < 0.7:
            contacts.append(("a", "b", "c"))          # rocked back: not a new face
        else:
            contacts.append(("b", "d", "e"))          # a new face
    tensions = [(10.0, 50.0), (80.5, 20.0), (30.0, 40.0)]
    s = roll_summary(centres, t, contacts, ("c1", "c2"), tensions)
    assert s.distance == pytest.approx(1.3) and s.displacement == pytest.approx((1.2, 0.5))
    assert [caps for _, caps in s.visited] == [("a", "b", "c"), ("a", "b", "d"), ("a", "b", "c"), ("b", "d", "e")]
    assert s.faces == 2
    assert s.peak_tensions == {"c1": 80.5, "c2": 50.0}
    lines = s.lines()
    assert lines[0].startswith("distance rolled: 1.300 m") and "faces rolled: 2" in lines[1]
    assert "c1 80.5 N, c2 50.0 N" in lines[2]
    assert all(math.isfinite(v) for v in s.displacement)


def test_the_roll_summary_of_no_samples_says_so():
    s = roll_summary([], [], [], (), [])
    assert s.distance == 0.0 and s.faces == 0 and s.peak_tensions == {}
    assert s.lines()[-1] == "peak tensions: no joint states with a measured tension received"


def test_the_roll_summary_leaves_out_the_cables_without_a_tension_sensor():
    nan = math.nan                                 # joint_states' effort of a cable not measured
    s = roll_summary([], [], [], ("c1", "c2"), [(nan, 5.0), (nan, 7.5), (nan, 2.0)])
    assert s.peak_tensions == {"c2": 7.5}
    s = roll_summary([], [], [], ("c1", "c2"), [(nan, nan)])
    assert s.peak_tensions == {} and s.lines()[-1].endswith("no joint states with a measured tension received")


def _glide_then_stop(stop: float, face_from: float, dt: float = 0.01, end: float = 4.0):
    """A robot whose centre glides at 0.3 m/s along x until ``stop`` [s], then stands; on the
    edge (a, b) until ``face_from`` [s], then on the face (a, b, c). Samples every ``dt`` s."""
    k = np.arange(round(end / dt) + 1)
    t = k * dt
    x = 0.3 * np.minimum(t, stop)
    centres = np.column_stack([x, np.zeros_like(x), np.full_like(x, 0.7)])
    contacts = [("a", "b") if ti < face_from else ("a", "b", "c") for ti in t]
    return t, centres, contacts


def test_the_robot_is_at_rest_once_a_face_and_its_centre_hold_still():
    t, centres, contacts = _glide_then_stop(stop=2.0, face_from=1.0)
    # still from 2.0 s on, on the face since 1.0 s: at rest once the centre REST_HOLD_S
    # earlier is within REST_SPEED * REST_HOLD_S of its final place (0.3 m/s before 2.0 s)
    settled = 2.0 + REST_HOLD_S - REST_SPEED * REST_HOLD_S / 0.3
    assert rest_time(t, centres, t, contacts, after=0.0) == pytest.approx(settled, abs=0.011)
    assert rest_time(t, centres, t, contacts, after=3.2) == pytest.approx(3.2, abs=0.011)
    # on the face only from 3.0 s: the face must hold too
    t, centres, contacts = _glide_then_stop(stop=2.0, face_from=3.0)
    assert rest_time(t, centres, t, contacts, after=0.0) == pytest.approx(3.0 + REST_HOLD_S, abs=0.011)
    # still on an edge: never at rest
    t, centres, contacts = _glide_then_stop(stop=2.0, face_from=9.0)
    assert rest_time(t, centres, t, contacts, after=0.0) is None


def test_a_robot_gliding_on_a_face_is_not_at_rest():
    """The 6-bar after a gait can coast on a face with its caps rolling (no rolling resistance
    in the model): three caps down, yet moving; a creep just over REST_SPEED is moving too."""
    t, centres, contacts = _glide_then_stop(stop=9.0, face_from=0.0)
    assert rest_time(t, centres, t, contacts, after=0.0) is None
    creep = centres.copy()
    creep[:, 1] = 1.05 * REST_SPEED * t
    creep[:, 0] = 0.0
    assert rest_time(t, creep, t, contacts, after=0.0) is None
    creep[:, 1] = 0.95 * REST_SPEED * t
    assert rest_time(t, creep, t, contacts, after=0.0) == pytest.approx(REST_HOLD_S, abs=0.011)
    assert rest_time([], [], [], [], after=0.0) is None
