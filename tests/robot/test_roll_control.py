"""The closed-loop rolling gait (:mod:`tensegrity_core.robot.roll_control`) on the simulated
6-bar: asked for N faces it rolls exactly N (counted independently from the contact state by
:mod:`tensegrity_core.robot.faces`: faces rested on, and hull faces touched at all) and rests,
for N = 1..4 towards any heading, each run starting on the face the last one ended on; bad
requests are refused with one line."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.robot.faces import edge_by_edge, faces_rolled, faces_touched, faces_visited
from tensegrity_core.robot.loading import load_robot
from tensegrity_core.robot.roll_control import TIPS_DIR, RollController, TipMoves
from tensegrity_core.robot.statics import rest_shape
from tensegrity_core.robot.tipping import hull_faces
from tensegrity_core.sim import compile_scene, load_scene
from tensegrity_core.sim.control_loop import ControlLoop

# among the suite's longest files: ./run test starts them first (tests/conftest.py)
pytestmark = pytest.mark.slow

#: The control rate [Hz] (the robots' usual 50 Hz loop).
RATE = 50.0
_SIX_BAR = load_robot("six_bar")
_SIX_BAR_MOVES = TipMoves(_SIX_BAR)


@pytest.fixture(scope="module")
def rest_scene():
    """The 6-bar resting on its drawn face, compiled once for the module."""
    scene = load_scene("six_bar_rest").with_duration(400.0)
    return scene, compile_scene(scene), TipMoves(scene.model.robot)


def _roll(model, state, controller):
    """Run ``controller`` from ``state``; from the contact state of the samples, independently
    of the controller: the faces rolled (rested on), the hull faces touched beyond the first
    (however briefly), the caps (node indices) of the last face and of the first; and it
    crossed one edge at a time."""
    samples = ControlLoop(model, state, controller, rate=RATE).run(20.0, after=1.0)
    seen = model.observe(samples)
    contact = seen["contact_forces"] > 0.0
    faces = faces_visited(seen["t"], contact)
    caps = model.plan.cap_node
    touching = [caps[row] for row in contact]
    assert edge_by_edge(touching, controller.moves.faces), controller.visited
    touched = faces_touched(touching, controller.moves.faces)
    return faces_rolled(faces), len(touched) - 1, {int(caps[i]) for i in faces[-1][1]}, faces[0][1]


@settings(max_examples=4)
@given(angle=st.floats(-np.pi, np.pi), counts=st.lists(st.integers(1, 4), min_size=3, max_size=3))
def test_the_controller_rolls_exactly_the_requested_faces(rest_scene, angle, counts):
    """From the drawn face, towards any heading, runs asked for 1-4 faces in turn (each
    starting where the last ended: closed and open faces) roll exactly the requested
    faces, counted independently from the contact state both as faces rested on and as hull
    faces touched at all, one edge at a time (none rolled through), and the robot rests on the face the
    controller reached, 1 s after its last tip."""
    scene, model, moves = rest_scene
    robot = scene.model.robot
    state = model.initial_state(t_end=400.0)
    heading = np.array([np.cos(angle), np.sin(angle)])
    x0 = model.observe_now(state)["centre_of_mass"][:2]
    travel = 0
    for n in counts:
        controller = RollController(robot, n, heading=heading, moves=moves)
        rolled, touched, last, _ = _roll(model, state, controller)
        assert controller.done, (n, controller.visited)
        assert rolled == touched == n, (n, rolled, touched, controller.visited)
        assert last == set(controller.visited[-1])
        travel += n
    moved = model.observe_now(state)["centre_of_mass"][:2] - x0
    assert moved @ heading > 0.2 * travel               # towards the heading, metres (~0.5 m a face)


def test_the_controller_rolls_the_requested_faces_from_where_the_last_run_ended(rest_scene):
    """N = 1, 2, 3, 4 towards +x, each run from where the last ended: four different start
    faces, and the centre of mass moves more than a metre along x."""
    scene, model, moves = rest_scene
    state = model.initial_state(t_end=400.0)
    starts, x0 = [], model.observe_now(state)["centre_of_mass"][0]
    for n in (1, 2, 3, 4):
        controller = RollController(scene.model.robot, n, heading=(1.0, 0.0), moves=moves)
        rolled, touched, last, start = _roll(model, state, controller)
        assert controller.done and rolled == touched == n, (n, rolled, touched, controller.visited)
        assert last == set(controller.visited[-1])
        starts.append(start)
    assert len(set(starts)) == 4
    assert model.observe_now(state)["centre_of_mass"][0] - x0 > 1.0


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
    with pytest.raises(ValueError, match="speed of a move must be a positive number of m/s, got 0.0"):
        RollController(robot, 1, speed=0.0)


@settings(max_examples=60, deadline=None)
@given(st.tuples(st.floats(allow_nan=False, allow_infinity=False), st.floats(allow_nan=False, allow_infinity=False))
       .filter(lambda h: h != (0.0, 0.0)))
def test_any_finite_nonzero_heading_is_its_unit_direction(heading):
    """Every finite nonzero (x, y) is a direction, however small or large its numbers (the CLI's
    ``--heading 1e-300 0`` once raised, and ``1e308 1e308`` overflowed to a heading of (0, 0)):
    the controller's heading is the unit vector along it. Pure; ~0.2 s for the 60 examples."""
    controller = RollController(_SIX_BAR, 1, heading=heading, moves=_SIX_BAR_MOVES)
    u = controller.heading
    assert abs(float(np.hypot(u[0], u[1])) - 1.0) <= 4e-16
    x, y = heading
    for component, along in ((u[0], x), (u[1], y)):          # the same signs (or rounded to 0 beside a
        assert component == 0.0 or np.sign(component) == np.sign(along)   # component 1e300 times larger)
    # parallel: u = h / |h|, so u_x |y| = u_y |x| when both are scaled by the larger one
    scale = max(abs(x), abs(y))
    assert abs(u[0] * (y / scale) - u[1] * (x / scale)) <= 4e-16


def test_the_strict_counts_see_a_face_crossed_on_two_caps():
    """``faces_touched`` and ``edge_by_edge`` on hand-written contact sequences over the
    6-bar's hull: rolling n0 n7 n9 -> n0 n4 n7 -> n0 n4 n8 touches each face, one edge at a
    time; going from n0 n7 n9 to n0 n4 n8 on the caps n0 n4 alone (n0 n4 n7 never touching
    with all three) touches two faces but crosses two edges between them."""
    robot = load_robot("six_bar")
    faces = hull_faces(rest_shape(robot).nodes)
    index = {n: i for i, n in enumerate(robot.node_names)}

    def caps(*names):
        return [index[n] for n in names]

    rolled = [caps("n0", "n7", "n9"), caps("n0", "n7"), caps("n0", "n4", "n7"), caps("n0", "n4"),
              caps("n0", "n4", "n8")]
    assert [sorted(f) for f in faces_touched(rolled, faces)] == [sorted(caps(*f)) for f in
                                                                  (("n0", "n7", "n9"), ("n0", "n4", "n7"),
                                                                   ("n0", "n4", "n8"))]
    assert edge_by_edge(rolled, faces)
    skipped = [caps("n0", "n7", "n9"), caps("n0", "n7"), caps("n0"), caps("n0", "n4"), caps("n0", "n4", "n8")]
    assert len(faces_touched(skipped, faces)) == 2
    assert not edge_by_edge(skipped, faces)


def test_a_rate_the_models_step_cannot_take_is_refused(rest_scene):
    """The 6-bar steps 1 ms at a time and its motors take a command at a step's start, so a
    controller is sampled at 1000 Hz at most (the scene's ``control`` check, here for the
    Python API); a rate that is no positive number is refused too."""
    import math

    from tensegrity_core.errors import ParameterError

    scene, model, _ = rest_scene
    assert scene.integrator.method == "RK4" and scene.integrator.max_step == 0.001
    state = model.initial_state(t_end=1.0)
    controller = RollController(scene.model.robot, 1)
    with pytest.raises(ParameterError, match=r"^a controller sampled at 1001 Hz is faster than the robot's fixed "
                                             r"step of 0.001 s \(1000 Hz\), at which its commands act; give rate in "
                                             r"\(0, 1000\] Hz$"):
        ControlLoop(model, state, controller, rate=1001.0)
    assert ControlLoop(model, state, controller, rate=1000.0).rate == 1000.0     # one command a step
    for bad in (0.0, -50.0, math.nan, math.inf):
        with pytest.raises(ParameterError, match="the control rate must be a positive number of Hz"):
            ControlLoop(model, state, controller, rate=bad)
