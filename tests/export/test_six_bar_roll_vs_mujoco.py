"""The six_bar under the shipped gait ``six_bar_roll``: the project against MuJoCo on the
scene's export, compared where the comparison is well posed.

Tipping over an edge is a bifurcation and the gait is open loop, so the two runs are
compared (docs/design/mujoco.md, "The project's robot dynamics against MuJoCo"):

- **faces**: the project's faces (rocking onto a face and straight back removed) are
  MuJoCo's in the same order, possibly passing one without resting on it, up to n1 n4 n11
  (~4.5 s); then both pass n2 n5 n6 and end the cycle on n3 n6 n9 (between, MuJoCo
  reaches n2 n5 n11 before n1 n2 n11 and the project the other way round: a model
  difference, robust in each to its step, floor stiffness and a 1e-6 m start, tabulated in
  docs/design/mujoco.md, so not asserted);
- **distance over the cycle** (13 s): the centres of mass travel the same distance on the
  floor within 10 % (project 3.56 m, MuJoCo 3.53 m with the shipped rolling and torsional
  friction). The distance is chaotic in both (docs/design/mujoco.md: 1.5-3.9 m in MuJoCo
  for torsional friction 2-5 mm), so this checks the two models at one shared point;
- **distance per gait step, up to the divergence**: at each of the gait's breakpoints
  until its third step ends (3.23 s, the centre of mass 1.2 m from its start) the two
  centres of mass are less than 10 % of MuJoCo's distance travelled apart. Right after
  that both robots leave the floor (3.5-3.8 s); MuJoCo's lands back on n1 n4 n7, the
  project's on n1 n4 n11, and from there the open-loop gait meets the two robots in
  different states and their paths part (not asserted: the docs tabulate it).
"""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco", reason="the mujoco extra is not installed (./run setup installs it)")

from tensegrity_core.export import export_mjcf  # noqa: E402
from tensegrity_core.robot.faces import faces_visited  # noqa: E402
from tensegrity_core.robot.gait import GAITS_DIR, gait_from_file  # noqa: E402
from tensegrity_core.sim import load_scene, simulate  # noqa: E402
from tests.mujoco_peer import play_gait  # noqa: E402

#: Simulated time [s]: the gait's whole cycle.
DURATION = 13.0
#: The face up to which the two runs pass the same faces in the same order (~4.5 s).
SAME_FACES_UNTIL = frozenset({"n1", "n4", "n11"})
#: The end of the gait's third step [s]: up to here the paths agree.
AGREE_UNTIL = 3.3


def without_rocking(faces: list[frozenset[str]]) -> list[frozenset[str]]:
    """The faces with every excursion onto a face and straight back removed (A B A -> A)."""
    out: list[frozenset[str]] = []
    for face in faces:
        if len(out) >= 2 and out[-2] == face:
            out.pop()
        elif not out or out[-1] != face:
            out.append(face)
    return out


def is_subsequence(short: list, long: list) -> bool:
    items = iter(long)
    return all(any(x == y for y in items) for x in short)


@pytest.fixture(scope="module")
def runs():
    scene = load_scene("six_bar_roll").with_duration(DURATION)
    robot = scene.model.robot
    run = simulate(scene)
    caps = robot.rods.ends.ravel()                       # the contact forces' order: each rod's two caps
    weight = robot.total_mass() * float(np.linalg.norm(robot.gravity))
    faces = [frozenset(robot.node_names[caps[i]] for i in f)        # as play_gait counts them
             for _, f in faces_visited(run.times, np.asarray(run.contact_forces) > 0.02 * weight, hold=0.0)]
    mid = 0.5 * (run.nodes[:, robot.rods.ends[:, 0]] + run.nodes[:, robot.rods.ends[:, 1]])
    com = np.einsum("r,trk->tk", robot.rods.mass, mid) / robot.rods.mass.sum()
    gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml")
    peer = play_gait(export_mjcf(scene).xml, gait, DURATION)
    return run.times, com, faces, peer, gait


def test_the_project_passes_mujocos_faces_in_mujocos_order(runs):
    _, _, faces, peer, _ = runs
    ours, theirs = without_rocking(faces), without_rocking([f for _, f in peer.faces])
    head = ours[:ours.index(SAME_FACES_UNTIL) + 1]
    assert is_subsequence(head, theirs[:theirs.index(SAME_FACES_UNTIL) + 1]), (ours, theirs)
    assert {"n2", "n5", "n6"} in ours and {"n2", "n5", "n6"} in theirs
    assert ours[-1] == theirs[-1] == {"n3", "n6", "n9"}, (ours, theirs)


def test_the_centres_of_mass_travel_the_same_distance_over_the_cycle_within_10_percent(runs):
    times, com, _, peer, _ = runs
    ours, theirs = np.hypot(*(com[-1] - com[0])[:2]), np.hypot(*(peer.com[-1] - peer.com[0])[:2])
    assert abs(ours - theirs) < 0.1 * theirs, (ours, theirs)


def test_the_centres_of_mass_agree_within_10_percent_per_gait_step_until_the_paths_part(runs):
    times, com, _, peer, gait = runs
    breakpoints = [t for t in gait.table()[0] if 0 < t <= AGREE_UNTIL]
    assert len(breakpoints) == 4
    for t in breakpoints:
        ours = com[np.searchsorted(times, t - 1e-9)] - com[0]
        theirs = peer.com[np.searchsorted(peer.times, t - 1e-9)] - peer.com[0]
        travelled = np.hypot(*theirs[:2])
        assert np.hypot(*(ours - theirs)[:2]) < 0.1 * travelled, (t, ours, theirs)
