"""The 6-bar rolls under the shipped gait: faces counted from the contact state."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.robot.faces import faces_rolled, faces_visited, progress_faces
from tensegrity_core.sim import compile_scene, load_scene

#: Sequences of faces as a rolling robot reports them: labels of a few faces, repeats allowed.
face_sequences = st.lists(st.frozensets(st.integers(0, 5), min_size=3, max_size=3), max_size=30)


def test_faces_are_held_contact_sets_of_three_caps_or_more():
    T = [[1, 1, 1, 0, 0]] * 5 + [[1, 1, 0, 0, 0]] * 2 + [[1, 1, 0, 1, 0]] * 5 + [[1, 1, 0, 1, 1]] * 1 \
        + [[1, 1, 1, 0, 0]] * 3 + [[0, 1, 0, 1, 1]] * 4
    times = np.arange(len(T)) * 0.1
    faces = faces_visited(times, np.array(T, dtype=bool), hold=0.25)
    assert [sorted(c) for _, c in faces] == [[0, 1, 2], [0, 1, 3], [0, 1, 2], [1, 3, 4]]   # not [0, 1, 3, 4]
    assert faces[1][0] == pytest.approx(0.7)
    assert faces_rolled(faces) == 2                        # the rock back to [0, 1, 2] is no new face


def test_a_rock_onto_a_face_and_back_is_no_progress():
    A, B, C, D = (frozenset(f) for f in ((0, 1, 2), (0, 1, 3), (1, 3, 4), (0, 2, 5)))
    assert progress_faces([A, B, A]) == [A]
    assert progress_faces([A, B, C, B, D]) == [A, B, D]            # C was an excursion from B
    assert progress_faces([A, B, C, B, A]) == [A]                  # all the way back
    assert progress_faces([A, A, B, B, C]) == [A, B, C]
    assert progress_faces([A, B, C, D, A]) == [A, B, C, D, A]      # round a vertex and on: four tips
    assert progress_faces([]) == []


@given(face_sequences)
def test_the_net_path_ends_where_the_robot_is_over_faces_it_passed_from_one_to_the_next(faces):
    path = progress_faces(faces)
    assert path[:1] == faces[:1] and path[-1:] == faces[-1:]
    steps = set(zip(faces, faces[1:]))
    assert all(pair in steps for pair in zip(path, path[1:]))      # each move of the path was one of the robot's
    assert all(p != q for p, q in zip(path, path[1:])) and all(p != r for p, r in zip(path, path[2:]))
    assert len(path) - 1 <= sum(p != q for p, q in zip(faces, faces[1:]))


@given(face_sequences, st.frozensets(st.integers(6, 9), min_size=3, max_size=3))
def test_a_rock_added_anywhere_leaves_the_progress_as_it_was(faces, elsewhere):
    for i in range(1, len(faces) + 1):
        rocked = faces[:i] + [elsewhere, faces[i - 1]] + faces[i:]
        assert progress_faces(rocked) == progress_faces(faces)


def test_the_six_bar_rolls_at_least_five_faces_in_10_s_towards_x():
    """The issue's target under the shipped gait: 5 faces of progress (rocks onto a face and
    back not counted) rested on within the first 10 s, each over an edge of the last."""
    scene = load_scene("six_bar_roll").with_duration(10.0)
    model = compile_scene(scene)
    state = model.initial_state(t_end=10.0)
    samples: list = []
    model.record(state, np.arange(1001) / 100, samples)
    o = model.observe(samples)
    path = progress_faces([caps for _, caps in faces_visited(o["t"], o["cap_contact"])])
    assert len(path) - 1 >= 5, path
    assert all(len(p & q) == 2 for p, q in zip(path, path[1:])), path
    com = o["centre_of_mass"]
    assert com[-1, 0] - com[0, 0] > 1.0                  # towards +x, metres
    assert abs(com[-1, 1] - com[0, 1]) < com[-1, 0] - com[0, 0]
    depth = model.plan.cap_radius - (o["nodes"][:, model.plan.cap_node] - model.plan.floor_point) @ model.plan.floor_normal
    assert depth.max() < 0.01                            # never deeper than 1 cm, even while tipping


def test_the_three_bar_crawls():
    """The shipped crawl moves the 3-bar's centre of mass more than 0.4 m over its first
    three 4 s cycles (after 2 s settling), on the floor (every cap less than 1 cm deep)."""
    scene = load_scene("three_bar_crawl").with_duration(14.0)
    model = compile_scene(scene)
    state = model.initial_state(t_end=14.0)
    samples: list = []
    model.record(state, np.arange(2, 15) * 1.0, samples)
    o = model.observe(samples)
    com = o["centre_of_mass"]
    assert np.hypot(*(com[-1, :2] - com[0, :2])) > 0.4
    depth = model.plan.cap_radius - (o["nodes"][:, model.plan.cap_node] - model.plan.floor_point) @ model.plan.floor_normal
    assert depth.max() < 0.01


def test_the_spine_bends_towards_the_cords_reeled_in_to_the_statics_shape():
    """In the second after the motors stop the spine sways (about 1 mm, its cords lightly
    damped) about the shape the statics finds for the final rest lengths under gravity: its
    nodes' mean over that second is within 0.5 mm of it; its top vertebra has moved more than
    5 cm towards +x and stays in the spine's plane of symmetry."""
    from tensegrity_core.robot.loading import load_robot
    from tensegrity_core.robot.statics import rest_shape
    from tensegrity_core.sim import simulate
    tr = simulate("spine_bend")
    robot = load_robot("spine")
    l0 = robot.cables.rest_length.copy()
    for side, rest in (("sidexp", 0.025), ("sidexm", 0.055)):
        l0[[n.startswith(side) for n in robot.cables.names]] = rest
    bent = rest_shape(robot, l0, gravity=True).nodes
    i = int(np.searchsorted(tr.times, 2.0))
    assert tr.success and tr.end_effector[-1, 0] - tr.end_effector[i, 0] > 0.05      # metres towards +x
    last = tr.times >= 4.0
    assert np.abs(tr.nodes[last].mean(axis=0) - bent).max() < 5e-4
    assert abs(tr.end_effector[-1, 1]) < 1e-6                                           # in its plane of symmetry


def test_the_shipped_roll_is_decisive_in_the_integration_step():
    """Over the whole gait (8 tips, 13.94 s, and the scene's rest to 20 s) the 6-bar rests on
    the same faces at 1 ms and 0.5 ms steps, once each: 8 faces of progress, none rocked onto
    and back (docs/design/mujoco.md, "A decisive roll"; MuJoCo's run is compared in
    tests/export/test_six_bar_roll_vs_mujoco.py)."""
    runs = []
    for step in (1e-3, 5e-4):
        scene = load_scene("six_bar_roll")
        scene = dataclasses.replace(scene, integrator=dataclasses.replace(scene.integrator, max_step=step))
        model = compile_scene(scene)
        state = model.initial_state(t_end=scene.duration)
        samples: list = []
        model.record(state, np.arange(round(scene.duration * 100) + 1) / 100, samples)
        o = model.observe(samples)
        runs.append([caps for _, caps in faces_visited(o["t"], o["cap_contact"])])
    assert runs[0] == runs[1], runs
    assert progress_faces(runs[0]) == runs[0] and len(runs[0]) - 1 == 8, runs[0]
