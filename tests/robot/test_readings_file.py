"""A robot's readings in the trajectory file: ``tensegrity simulate three_bar_drop -o run.npz``
(the CLI's entry point, in this process) writes the cable lengths and tensions, the IMUs' readings and the caps'
contact state; checked by reading the file with numpy alone against quantities computed here
from the file's node positions and the robot's description, and read back by
``Trajectory.from_npz``."""

from __future__ import annotations

import numpy as np

from tensegrity_core.robot.loading import robot_from_file, robot_path
from tensegrity_core.sim import Trajectory
from tensegrity_core.sim.trajectory import READINGS
from tensegrity_ros.cli import main

G = 9.81


def test_simulate_writes_the_robots_readings_into_the_npz_file(tmp_path):
    out = tmp_path / "run.npz"
    assert main(["simulate", "three_bar_drop", "-o", str(out)]) == 0
    robot = robot_from_file(robot_path("three_bar"))
    with np.load(out, allow_pickle=False) as z:
        got = {k[len("reading_"):]: z[k] for k in z.files if k.startswith("reading_")}
        nodes = z["nodes"]
    assert set(got) == set(READINGS)
    # every cable is sensed (sensors.cable_length: all): lengths from the nodes [m]
    a, b = robot.cables.ends.T
    np.testing.assert_allclose(got["cable_lengths"], np.linalg.norm(nodes[:, b] - nodes[:, a], axis=2), rtol=0,
                               atol=1e-12)
    assert got["cable_tensions"].shape == (len(nodes), 0)            # cable_tension: none
    # two IMUs (r01, r23): unit quaternions; nearly at rest after 3 s (it still rocks a little)
    # they feel about 1 g
    assert got["imu_orientation"].shape == (len(nodes), 2, 4)
    np.testing.assert_allclose(np.linalg.norm(got["imu_orientation"], axis=2), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(got["imu_specific_force"][-1], axis=1), G, rtol=3e-2)
    # lifted 5 cm: no cap touches at first; at rest three caps carry the 12 kg
    assert not got["cap_contact"][0].any() and got["cap_contact"][-1].sum() == 3
    assert np.all(got["friction_forces"][~got["cap_contact"]] == 0.0)
    np.testing.assert_allclose(got["centre_of_mass"][0, 2], robot.nodes[:, 2].mean() + 0.05, atol=1e-12)
    back = Trajectory.from_npz(out)
    for k, v in got.items():
        np.testing.assert_array_equal(back.readings[k], v)
