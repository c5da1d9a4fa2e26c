"""The 6-bar rolls under the shipped gait: faces counted from the contact state."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.robot.faces import faces_rolled, faces_visited
from tensegrity_core.sim import compile_scene, load_scene


def test_faces_are_held_contact_sets_of_three_caps_or_more():
    T = [[1, 1, 1, 0, 0]] * 5 + [[1, 1, 0, 0, 0]] * 2 + [[1, 1, 0, 1, 0]] * 5 + [[1, 1, 0, 1, 1]] * 1 \
        + [[1, 1, 1, 0, 0]] * 3 + [[0, 1, 0, 1, 1]] * 4
    times = np.arange(len(T)) * 0.1
    faces = faces_visited(times, np.array(T, dtype=bool), hold=0.25)
    assert [sorted(c) for _, c in faces] == [[0, 1, 2], [0, 1, 3], [0, 1, 2], [1, 3, 4]]   # not [0, 1, 3, 4]
    assert faces[1][0] == pytest.approx(0.7)
    assert faces_rolled(faces) == 2                        # the rock back to [0, 1, 2] is no new face


def test_the_six_bar_rolls_at_least_five_faces_in_10_s_towards_x():
    scene = load_scene("six_bar_roll").with_duration(10.0)
    model = compile_scene(scene)
    state = model.initial_state(t_end=10.0)
    samples: list = []
    model.record(state, np.arange(1001) / 100, samples)
    o = model.observe(samples)
    faces = faces_visited(o["t"], o["cap_contact"])
    assert faces_rolled(faces) >= 5
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
