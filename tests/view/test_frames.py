"""The view's frames, geometry, colours, inputs and plot history, without a browser or ROS."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tensegrity_core.sim import Simulator
from tensegrity_ros.view.colors import SLACK, tension_colors
from tensegrity_ros.view.frame import Frame, Topology
from tensegrity_ros.view.frames import frame_of_observation, scene_topology
from tensegrity_ros.view.geometry import grid_lines, segment_poses, unit_cylinder, z_to
from tensegrity_ros.view.inputs import InputSpec, clamp
from tensegrity_ros.view.plots import SeriesHistory, axis_ranges

finite = st.floats(-10.0, 10.0, allow_nan=False)


@given(st.tuples(finite, finite, finite).filter(lambda v: math.hypot(*v) > 1e-6))
def test_z_to_turns_z_onto_every_direction(d):
    """scipy's rotation of +Z by the quaternion (scipy orders it x, y, z, w) is d / |d|."""
    w, x, y, z = z_to(np.array([d]))[0]
    turned = Rotation.from_quat([x, y, z, w]).apply([0.0, 0.0, 1.0])
    np.testing.assert_allclose(turned, np.array(d) / np.linalg.norm(d), atol=1e-12)


def test_z_to_handles_minus_z_and_segments_of_zero_length():
    w, x, y, z = z_to(np.array([[0.0, 0.0, -2.0]]))[0]
    np.testing.assert_allclose(Rotation.from_quat([x, y, z, w]).apply([0, 0, 1]), [0, 0, -1], atol=1e-12)
    mid, wxyz, length = segment_poses(np.array([[1.0, 2.0, 3.0]]), np.array([[1.0, 2.0, 3.0]]))
    assert length[0] == 0 and np.allclose(mid, [[1, 2, 3]]) and np.allclose(wxyz, [[1, 0, 0, 0]])


def test_segment_poses_put_a_unit_cylinder_on_the_segment():
    a, b = np.array([[0.0, 0.0, 0.0]]), np.array([[3.0, 4.0, 0.0]])
    mid, wxyz, length = segment_poses(a, b)
    assert length[0] == pytest.approx(5.0) and np.allclose(mid, [[1.5, 2.0, 0.0]])
    w, x, y, z = wxyz[0]
    ends = Rotation.from_quat([x, y, z, w]).apply([[0, 0, -0.5], [0, 0, 0.5]]) * length[0] + mid
    np.testing.assert_allclose(ends, np.vstack([a, b]), atol=1e-12)


@pytest.mark.parametrize("scene", ["class2_at_rest", "spine_release", "table_gravity", "six_bar_roll", "spine_bend"])
def test_a_frame_draws_the_members_the_core_measures(scene):
    """The topology's node pairs applied to the frame's nodes give the core's member lengths
    (a wrong pair, an axis lost on the way, a swapped node all change a length)."""
    sim = Simulator(scene)
    topology = scene_topology(sim.scene)
    obs = sim.observe()
    frame = frame_of_observation(obs, topology, "paused")
    ends = topology.members
    lengths = np.linalg.norm(frame.nodes[ends[:, 1]] - frame.nodes[ends[:, 0]], axis=1)
    np.testing.assert_allclose(lengths, obs.member_lengths, rtol=1e-12, atol=1e-12)
    assert set(frame.series) == {k for _title, keys in topology.series_groups for k in keys}


def test_the_class2_topology_has_the_papers_members():
    topology = scene_topology(Simulator("class2_at_rest").scene)
    assert topology.kind == "class2" and topology.node_names[topology.end_effector] == "D"
    kinds = dict(zip(topology.member_names, topology.member_kinds))
    assert [n for n, k in kinds.items() if k == "actuator"] == ["1_AB", "2_BC"]
    assert sorted(n for n, k in kinds.items() if k == "bar") == ["10_CE", "5_AE", "6_BF", "9_BD"]


def test_a_robot_is_drawn_with_its_rods_caps_cables_floor_and_the_caps_on_the_floor():
    """Rods are bars at the rod radius, cables strings, the floor drawn; a contact is a cap
    whose centre is lower than its radius above the floor z = 0 (it penetrates: the
    contact model's delta = r - z > 0), with a positive normal force. Checked along the roll,
    on faces whose caps the core lists in another order than the nodes (the
    6-bar's rods 1, 3 and 4 run from their higher-numbered node: its caps n3, n2, n7, n6,
    n9, n8 sit at other indices of the core's cap forces than of its nodes)."""
    sim = Simulator("six_bar_roll")
    robot = sim.scene.model.robot
    topology = scene_topology(sim.scene)
    assert topology.kind == "robot" and topology.floor
    assert topology.bar_radius == 0.02 and topology.node_radius == 0.05      # the shipped six_bar.yaml
    assert [topology.member_kinds[i] for i in topology.of_kind("bar")] == ["bar"] * 6
    assert len(topology.of_kind("string")) == 24
    reordered = set()
    for t in (0.35, 1.0, 1.4):                        # rolling: two or three caps down
        sim.advance(t)
        obs = sim.observe()
        frame = frame_of_observation(obs, topology, "playing")
        down = {i for i, z in enumerate(frame.nodes[:, 2]) if z < robot.rods.cap_radius[0]}
        touching = {int(np.flatnonzero((frame.nodes == p).all(axis=1))[0]) for p, _f in frame.contacts}
        assert touching and touching == down, f"t = {t} s"
        assert all(f > 0 for _p, f in frame.contacts)
        assert {f"N:{topology.node_names[i]}" for i in touching} == {k for k, v in frame.series.items()
                                                                      if k.startswith("N:") and v > 0}
        reordered |= {i for i in touching if obs.cap_names.index(topology.node_names[i]) != i}
    assert reordered, "no cap listed out of node order touched the floor: the check above cannot tell the orders"


def test_a_general_topology_carries_its_bodies_and_the_floor():
    topology = scene_topology(Simulator("table_gravity").scene)
    assert [name for name, _ in topology.bodies] == ["bottom", "top"] and topology.floor


def test_a_topology_refuses_pairs_outside_its_nodes():
    with pytest.raises(ValueError, match="outside"):
        Topology("general", ("a", "b"), ("m",), np.array([[0, 2]]), ("bar",))
    with pytest.raises(ValueError, match="unknown member kinds"):
        Topology("general", ("a", "b"), ("m",), np.array([[0, 1]]), ("rope",))


def test_tension_colours_start_at_the_maps_first_colour_and_grey_slack():
    """plasma starts at #0d0887 (13, 8, 135), matplotlib's published first colour."""
    rgb = tension_colors(np.array([1e-12, 0.0, -3.0, 2.0]), scale=2.0)
    assert tuple(rgb[0]) == (13, 8, 135)
    assert tuple(rgb[1]) == SLACK and tuple(rgb[2]) == SLACK
    assert tuple(rgb[3]) != tuple(rgb[0])


def test_tension_colours_follow_matplotlibs_plasma_within_3_5_of_255():
    """Over the whole scale (0 N to the scale, and beyond: held at the top), the colours are
    matplotlib's plasma on [0, MAP_TOP] within 3.5 units of 255 per channel (interpolation and rounding)."""
    from matplotlib import colormaps

    from tensegrity_ros.view.colors import MAP_TOP

    t = np.linspace(1e-9, 12.0, 6001)
    expected = np.asarray(colormaps["plasma"](MAP_TOP * np.clip(t / 10.0, 0.0, 1.0)))[:, :3] * 255
    assert np.abs(tension_colors(t, scale=10.0).astype(float) - expected).max() <= 3.5


def test_clamp_keeps_values_within_limits_and_says_when_it_clamps():
    spec = InputSpec("f1", "N", -5.0, 5.0, 0.0)
    assert clamp(spec, 2.5, 0.0).value == 2.5 and clamp(spec, 2.5, 0.0).note == ""
    over = clamp(spec, 7.0, 0.0)
    assert over.value == 5.0 and "clamped to 5 N" in over.note and "outside [-5, 5] N" in over.note
    assert clamp(spec, -9.0, 0.0).value == -5.0
    refused = clamp(spec, float("nan"), 1.5)
    assert refused.value == 1.5 and "not a number" in refused.note
    with pytest.raises(ValueError):
        InputSpec("f1", "N", 1.0, 1.0, 1.0)


def _frame(t: float, v: float) -> Frame:
    return Frame(t=t, nodes=np.zeros((1, 3)), member_forces=np.zeros(0), series={"q:a": v})


def test_the_history_keeps_its_window_and_restarts_when_time_goes_back():
    h = SeriesHistory(window=1.0)
    for k in range(31):
        h.add(_frame(0.1 * k, float(k)))
    t, a = h.arrays(("q:a",))
    assert t[0] == pytest.approx(2.0) and t[-1] == pytest.approx(3.0) and a[-1] == 30.0
    h.add(_frame(0.5, -1.0))
    t, a, missing = h.arrays(("q:a", "q:b"))
    assert list(t) == [0.5] and list(a) == [-1.0] and math.isnan(missing[0])


def test_axis_ranges_cover_the_data_and_never_collapse():
    (t0, t1), (lo, hi) = axis_ranges((np.array([1.0, 2.0]), np.array([0.0, 10.0]), np.array([np.nan, -2.0])))
    assert (t0, t1) == (1.0, 2.0) and lo == pytest.approx(-2.6) and hi == pytest.approx(10.6)
    (t0, t1), (lo, hi) = axis_ranges((np.array([3.0]), np.array([0.7])))    # one sample: a real range
    assert t1 > t0 == 3.0 and lo < 0.7 < hi
    assert axis_ranges((np.zeros(0),)) == ((0.0, 1.0), (-0.05, 1.05))


@pytest.mark.parametrize("sections", [3, 16, 40])
def test_the_unit_cylinder_is_closed_outward_and_of_its_polygons_volume(sections):
    """trimesh (an independent mesh library) finds the mesh watertight, its faces wound
    outward and its volume the regular polygon's area times the height 1; it spans z = -1/2..1/2
    at radius 1."""
    trimesh = pytest.importorskip("trimesh")
    vertices, faces = unit_cylinder(sections)
    mesh = trimesh.Trimesh(vertices=vertices.astype(float), faces=faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume == pytest.approx(0.5 * sections * math.sin(2 * math.pi / sections), rel=1e-6)
    np.testing.assert_allclose(mesh.bounds[:, 2], [-0.5, 0.5])
    np.testing.assert_allclose(np.hypot(vertices[:-2, 0], vertices[:-2, 1]), 1.0, rtol=1e-6)


@given(st.floats(0.01, 100.0), st.integers(1, 60), st.integers(1, 12))
def test_the_floor_grid_is_square_evenly_spaced_with_sections_every_nth_line_from_its_centre(half, cells, every):
    lines, section = grid_lines(half, cells, every)
    assert lines.shape == (2 * (cells + 1), 2, 3) and section.shape == (2 * (cells + 1),)
    assert np.all(lines[:, :, 2] == 0.0)
    np.testing.assert_allclose(np.linalg.norm(lines[:, 1] - lines[:, 0], axis=1), 2 * half, rtol=1e-6)
    for axis, group in ((1, lines[: cells + 1]), (0, lines[cells + 1:])):   # parallel to X, then to Y
        offsets = group[:, 0, axis]
        np.testing.assert_allclose(group[:, 1, axis], offsets)                 # each line straight
        np.testing.assert_allclose(np.diff(offsets), 2 * half / cells, rtol=1e-5)
        np.testing.assert_allclose(offsets[[0, -1]], [-half, half], rtol=1e-6)
    centre = np.arange(cells + 1) - cells // 2          # lines from the centre one (a middle one if cells is odd)
    assert list(section[: cells + 1]) == [k % every == 0 for k in centre]
    assert list(section[cells + 1:]) == list(section[: cells + 1])
