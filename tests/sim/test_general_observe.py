"""What a general structure's observation adds: members' rest lengths, length rates and slack
flags, rigid-body frames and velocities; and what each model's inputs take (its Interface).

Oracles: fourth-order central differences in time of the observed lengths, positions and
orientations (independent of the simulator's velocity code), the rigid-body placement
rebuilt in the test from the drawing and a quaternion (Hamilton's formula written here),
the members' slack condition from the structure's kinds and rest lengths.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from tensegrity_core.general import structure_from_dict
from tensegrity_core.sim import Simulator, load_scene

from .test_general import BODIES, LINE, general_scene


def _derivative(values: np.ndarray, h: float) -> np.ndarray:
    """Fourth-order central difference along the first axis (samples 2..N-3)."""
    v = values
    return (-v[4:] + 8 * v[3:-1] - 8 * v[1:-3] + v[:-4]) / (12 * h)


def _matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def observed(scene, h: float, n: int) -> SimpleNamespace:
    """The model's observations at ``k h``, k < n, as attributes."""
    sim = Simulator(scene)
    samples: list = []
    sim.model.record(sim.state, np.arange(n) * h, samples)
    return SimpleNamespace(**sim.model.observe(samples), body_names=sim.model.names.body_names)


@pytest.fixture(scope="module")
def bodies_run():
    """The two floating triangles released from the drawing (not an equilibrium: they move)."""
    h = 2e-4
    return structure_from_dict(BODIES), observed(general_scene(BODIES, ["inertia", "springs"]), h, 150), h


def test_length_rates_are_the_time_derivatives_of_the_lengths(bodies_run):
    structure, traj, h = bodies_run
    rates = traj.member_rates
    assert rates.shape == traj.member_lengths.shape and np.abs(rates).max() > 0.1     # it moves
    np.testing.assert_allclose(rates[2:-2], _derivative(traj.member_lengths, h), atol=1e-6 * np.abs(rates).max())


def test_slack_strings_carry_nothing_and_the_rest_lengths_are_the_drawn_ones(bodies_run):
    structure, traj, _ = bodies_run
    np.testing.assert_array_equal(traj.member_rest_lengths, np.broadcast_to(structure.rest_lengths,
                                                                            traj.member_lengths.shape))
    strings = np.array([k == "string" for k in structure.member_kinds])
    slack = strings & (traj.member_lengths < structure.rest_lengths)
    np.testing.assert_array_equal(traj.member_slack, slack)
    assert np.all(traj.member_forces[slack] == 0.0)
    assert np.all(traj.member_forces[~slack & strings] > 0.0)


def test_body_frames_place_the_drawn_bodies_and_their_velocities_are_derivatives(bodies_run):
    structure, traj, h = bodies_run
    assert traj.body_names == ("low", "high")
    for b, body in enumerate(structure.bodies):
        drawn = structure.nodes[list(body.nodes)]
        offsets = drawn - drawn.mean(axis=0)            # the frame: origin at the centre, world axes drawn
        q = traj.body_orientations[:, b]
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
        R = np.array([_matrix(qi) for qi in q])
        placed = traj.body_positions[:, b, None, :] + np.einsum("kij,nj->kni", R, offsets)
        np.testing.assert_allclose(placed, traj.nodes[:, list(body.nodes)], atol=1e-12)
        np.testing.assert_allclose(traj.body_velocities[2:-2, b], _derivative(traj.body_positions[:, b], h),
                                   atol=1e-6 * max(1.0, np.abs(traj.body_velocities).max()))
        dR = _derivative(R, h)
        W = np.einsum("kij,klj->kil", dR, R[2:-2])      # hat(omega) = dR/dt R^T (world frame)
        omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
        w = traj.body_angular_velocities[2:-2, b]
        assert np.abs(w).max() > 0.1
        np.testing.assert_allclose(w, omega, atol=1e-6 * np.abs(w).max())


def test_quasi_static_length_rates_follow_the_path():
    structure = dict(LINE, members=[{"nodes": ["a", "m"], "type": "actuator", "EA": 100.0, "rest_length": 1.0,
                                     "name": "act"},
                                    {"nodes": ["m", "b"], "type": "bar", "EA": 100.0, "rest_length": 1.0}])
    h = 1e-3
    scene = general_scene(structure, ["springs"], inputs={"act": {"law": "ramp", "from": 1.0, "to": 0.8, "t1": 1.0}})
    traj = observed(scene, h, 400)
    rates = traj.member_rates
    assert np.abs(rates).max() > 0.01
    np.testing.assert_allclose(rates[2:-2], _derivative(traj.member_lengths, h), atol=1e-9)
    np.testing.assert_array_equal(traj.member_rest_lengths[:, 0], traj.applied_forces[:, 0])


def test_each_model_says_what_its_inputs_take():
    class2 = Simulator("class2_at_rest").interface
    assert (class2.command, class2.inputs, class2.commanded, class2.members, class2.unit) == \
        ("force", ("f1", "f2"), (True, True), (0, 1), "N")
    assert Simulator("paper_fold").interface.commanded == (False, False)      # f_i = 10 rho_i t: a law
    table = Simulator("table_actuated")
    names = table.model.names
    iface = table.interface
    assert (iface.command, iface.inputs, iface.unit) == ("rest_length", ("long1", "long2", "long3"), "m")
    assert [names.member_names[i] for i in iface.members] == list(iface.inputs)
    assert all(names.member_kinds[i] == "actuator" for i in iface.members)
    assert iface.limits == ((0.0, math.inf),) * 3
    assert load_scene("spine_release") and Simulator("spine_release").interface.inputs == ()
