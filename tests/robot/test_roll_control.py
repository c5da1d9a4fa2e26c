"""The closed-loop rolling gait (:mod:`tensegrity_core.robot.roll_control`) on the simulated
6-bar: asked for N faces it rolls exactly N (counted independently from the contact state by
:mod:`tensegrity_core.robot.faces`) and rests, for N = 1..4, each run starting on the face the
last one ended on; bad requests are refused with one line."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.robot.faces import faces_rolled, faces_visited
from tensegrity_core.robot.loading import load_robot
from tensegrity_core.robot.roll_control import TIPS_DIR, RollController, TipMoves
from tensegrity_core.robot.statics import rest_shape
from tensegrity_core.robot.tipping import hull_faces
from tensegrity_core.sim import compile_scene, load_scene
from tensegrity_core.sim.general.robot.closed_loop import run_controlled

#: The control rate [Hz] (the robots' usual 50 Hz loop).
RATE = 50.0


@pytest.mark.xfail(strict=True, reason=(
    "with Coulomb's bound at every RK4 stage (issue 29) the first run, asked for 1 face, lands on n0 n4 n7 for "
    "60 ms, bounces on over the edge n0 n4 onto n0 n4 n8 (2 faces counted); runs 2-4 roll exactly. MuJoCo, "
    "under the same controller, rolls 1-4 exactly (tests/export/test_roll_control_mujoco.py)"))
def test_the_controller_rolls_the_requested_faces_from_where_the_last_run_ended():
    scene = load_scene("six_bar_rest").with_duration(60.0)
    model = compile_scene(scene)
    robot = scene.model.robot
    state = model.initial_state(t_end=60.0)
    moves = TipMoves(robot)
    caps = model.plan.cap_node
    starts, x0 = [], model.observe_now(state)["centre_of_mass"][0]
    for n in (1, 2, 3, 4):
        controller = RollController(robot, n, heading=(1.0, 0.0), moves=moves)
        samples = run_controlled(model, state, controller, rate=RATE, duration=20.0, after=1.0)
        seen = model.observe(samples)
        assert controller.done, (n, controller.visited)
        faces = faces_visited(seen["t"], seen["contact_forces"] > 0.0)
        assert faces_rolled(faces) == n, (n, faces)
        starts.append(faces[0][1])
        last = {int(caps[i]) for i in faces[-1][1]}
        assert last == set(controller.visited[-1])      # and it rests there, 1 s after the last tip
    assert len(set(starts)) == 4                         # four different start faces
    assert model.observe_now(state)["centre_of_mass"][0] - x0 > 1.0      # towards +x, metres


def test_the_shipped_table_holds_the_derived_moves():
    """The shipped 6-bar table is ``TipMoves.table()``: one face's moves re-derived here (the
    first face's, over each edge) equal it to its rounding (1 nm)."""
    import yaml

    robot = load_robot("six_bar")
    shipped = yaml.safe_load((TIPS_DIR / "six_bar.yaml").read_text())
    assert len(shipped["moves"]) == 3 * len(hull_faces(rest_shape(robot).nodes)) == 60
    fresh = TipMoves(robot)
    fresh._moves.clear()                                 # derive, not read
    names = {n: i for i, n in enumerate(robot.node_names)}
    for m in shipped["moves"][:3]:
        face, edge = tuple(names[n] for n in m["face"]), tuple(names[n] for n in m["edge"])
        row = fresh.command(face, edge)
        assert (row is None) == (m["rest_lengths"] is None)
        if row is not None:
            np.testing.assert_allclose(row, m["rest_lengths"], rtol=0, atol=1e-9)


def test_bad_requests_are_refused_with_one_line():
    robot = load_robot("six_bar")
    with pytest.raises(ValueError, match="number of faces to roll must be >= 0, got -1"):
        RollController(robot, -1)
    with pytest.raises(ValueError, match="heading must be a nonzero direction"):
        RollController(robot, 1, heading=(0.0, 0.0))
    with pytest.raises(ValueError, match="heading must be a nonzero direction"):
        RollController(robot, 1, heading=(np.nan, 1.0))
