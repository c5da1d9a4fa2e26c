"""Rigid bodies drawn as hulls in their body frames, moved by their poses (no browser, no ROS):
the poses recovered from moved node sets, the grouping by shape, and a real viser scene whose
instanced hulls, moved by the drawing, put every hull vertex on its body's node."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tensegrity_ros.view.geometry import rigid_poses
from tensegrity_ros.view.hulls import hull_groups

BAGS = Path(__file__).resolve().parents[2] / "bags"


@settings(max_examples=50, deadline=None)
@given(st.integers(3, 8), st.integers(1, 6), st.integers(0, 2**32 - 1))
def test_rigid_poses_recover_the_rotation_and_position_that_moved_the_template(k, b, seed):
    """Template moved by rotations and translations drawn by scipy: the poses are those
    (quaternion up to its sign), and carry the template onto the points."""
    rng = np.random.default_rng(seed)
    template = rng.uniform(-1.0, 1.0, (k, 3))
    turns = Rotation.random(b, random_state=rng)
    shift = rng.uniform(-5.0, 5.0, (b, 3))
    points = shift[:, None, :] + np.einsum("bij,kj->bki", turns.as_matrix(), template - template.mean(axis=0))
    pos, wxyz = rigid_poses(template, points)
    np.testing.assert_allclose(pos, shift, atol=1e-9)
    want = turns.as_quat(canonical=True, scalar_first=True)
    np.testing.assert_allclose(np.abs(np.sum(wxyz * want, axis=1)), 1.0, atol=1e-9)
    assert np.all(wxyz[:, 0] >= 0)


def test_rigid_poses_never_reflect():
    """A mirrored point set gets a proper rotation (det +1), the nearest one, not the mirror."""
    template = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    mirrored = template * [1.0, 1.0, -1.0]
    _, wxyz = rigid_poses(template, mirrored[None])
    assert np.linalg.det(Rotation.from_quat(wxyz[0], scalar_first=True).as_matrix()) == pytest.approx(1.0)


def test_a_body_with_a_point_not_finite_gets_no_pose_and_leaves_the_others_theirs():
    """A diverged simulation's state draws nothing for that body, and raises nothing."""
    template = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    points = np.stack([template + 1.0, template, template])
    points[1, 2, 0] = np.nan
    points[2, 0, 1] = np.inf
    pos, wxyz = rigid_poses(template, points)
    np.testing.assert_allclose(pos[0], template.mean(axis=0) + 1.0)
    np.testing.assert_allclose(wxyz[0], [1.0, 0.0, 0.0, 0.0], atol=1e-12)
    assert not np.isfinite(pos[1:]).all(axis=1).any()


def test_congruent_bodies_share_one_group_and_others_do_not():
    """Four copies of a tetrahedron with a centre node, each turned and moved: one group; the
    same shape scaled by 1.001, or with its nodes listed in another order, is another."""
    rng = np.random.default_rng(7)
    shape = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, -0.05], [-0.1, 0.0, -0.05], [0.0, 0.1, 0.05], [0.0, -0.1, 0.05]])
    copies = [Rotation.random(random_state=rng).apply(shape) + rng.uniform(-1, 1, 3) for _ in range(4)]
    nodes = np.vstack(copies + [shape * 1.001 + 3.0, shape[[1, 0, 2, 3, 4]] - 3.0])
    bodies = [list(range(5 * i, 5 * i + 5)) for i in range(6)]
    groups = hull_groups(bodies, nodes, size=1.0)
    assert [g.nodes.tolist() for g in groups] == [bodies[:4], [bodies[4]], [bodies[5]]]
    assert len(groups[0].faces) == 4                  # the hull of the tetrahedron: the centre node is inside
    np.testing.assert_allclose(groups[0].template.mean(axis=0), 0.0, atol=1e-15)


def test_the_drawn_hulls_put_each_vertex_on_its_bodys_node():
    """The spine's bag in a real viser scene: its 10 vertebrae are one instanced mesh; after the
    drawing shows the bag's last state (the spine bent from its first), every vertex of every
    instance -- the mesh's vertices moved by the instance's pose, as the page draws them -- is
    at its vertebra's node (float32 of a 0.5 m structure: to 1e-6 m)."""
    from tensegrity_ros.view.bag_source import BagSource
    from tensegrity_ros.view.drawing import StructureDrawing
    from tensegrity_ros.view.server import start_server

    bag = BagSource(BAGS / "spine_release")
    first, last = bag.frame_at(0), bag.frame_at(len(bag._times) - 1)
    assert np.abs(last.nodes - first.nodes).max() > 0.005         # the vertebrae moved (by up to 1 cm)
    server = start_server(port=0)
    try:
        drawing = StructureDrawing(server.scene, bag.topology, first)
        drawing.show(last)
        (mesh,) = drawing.bodies
        (group,) = drawing._hulls
        assert group.nodes.shape == (10, 5)
        turns = Rotation.from_quat(np.asarray(mesh.batched_wxyzs, dtype=float), scalar_first=True)
        vertices = np.asarray(mesh.vertices, dtype=float)
        drawn = np.stack([turns[i].apply(vertices) for i in range(len(turns))]) + np.asarray(mesh.batched_positions)[:, None]
        np.testing.assert_allclose(drawn, last.nodes[group.nodes], atol=1e-6)
    finally:
        server.stop()
