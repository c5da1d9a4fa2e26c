"""The six_bar under the shipped gait ``six_bar_roll``: the project against MuJoCo on the
scene's export (RK4 at the scene's 1 ms step, as the project integrates it), over the whole
gait (docs/design/mujoco.md, "A decisive roll").

- **faces**: both runs pass the same faces in the same order, rockings included, and with
  every excursion onto a face and straight back removed they are the faces of the gait's
  quasi-static derivation, in its order;
- **distance per gait cycle**: at the end of the cycle the two centres of mass are less than
  10 % of MuJoCo's distance travelled apart (the issue's criterion).
"""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.export import export_mjcf
from tensegrity_core.robot.faces import faces_visited, progress_faces
from tensegrity_core.robot.gait import GAITS_DIR, gait_from_file
from tensegrity_core.sim import load_scene, simulate
from tests.export.test_robot_mujoco import PLANNED_FACES
from tests.mujoco_peer import play_gait


@pytest.fixture(scope="module")
def runs():
    scene = load_scene("six_bar_roll")
    gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml")
    duration = scene.duration
    assert duration > gait.duration                        # the whole cycle
    robot = scene.model.robot
    run = simulate(scene)
    caps = robot.rods.ends.ravel()                       # the contact forces' order: each rod's two caps
    weight = robot.total_mass() * float(np.linalg.norm(robot.gravity))
    faces = [frozenset(robot.node_names[caps[i]] for i in f)        # as play_gait counts them
             for _, f in faces_visited(run.times, np.asarray(run.contact_forces) > 0.02 * weight, hold=0.0)]
    mid = 0.5 * (run.nodes[:, robot.rods.ends[:, 0]] + run.nodes[:, robot.rods.ends[:, 1]])
    com = np.einsum("r,trk->tk", robot.rods.mass, mid) / robot.rods.mass.sum()
    peer = play_gait(export_mjcf(scene).xml, gait, duration)
    return com, faces, peer, gait


def test_both_pass_the_derivations_faces_in_the_same_order_over_the_whole_gait(runs):
    _, faces, peer, _ = runs
    theirs = [f for _, f in peer.faces]
    assert faces == theirs, (faces, theirs)
    assert progress_faces(faces) == PLANNED_FACES, faces


def test_the_centres_of_mass_agree_within_10_percent_over_the_gait_cycle(runs):
    com, _, peer, _ = runs
    ours = com[-1, :2] - com[0, :2]
    theirs = peer.com[-1, :2] - peer.com[0, :2]
    assert ours[0] > 3.0                                  # it rolled towards +x [m]
    assert np.hypot(*(ours - theirs)) < 0.1 * np.hypot(*theirs), (ours, theirs)
