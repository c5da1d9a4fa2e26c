"""The statics and the dynamics share the robot's cable element: the spine's shape form-found
by the statics (``robot.statics.rest_shape``) for new motor rest lengths, under gravity on its
fixed base, is a rest state of the dynamics (the robot drawn there with those rest lengths
stays put), and the cable tensions the statics computes are those the dynamics applies."""

from __future__ import annotations

import numpy as np

from tensegrity_core.robot.generators import spine
from tensegrity_core.robot.robot_schema import robot_from_dict
from tensegrity_core.robot.statics import rest_shape
from tensegrity_core.sim import load_scene, simulate


def test_the_statics_rest_shape_for_new_motor_rest_lengths_is_a_rest_state_of_the_dynamics():
    """The +x side cords' motors at 0.97 of their drawn rest lengths: the statics bends the
    spine (nodes move up to 13 mm from the drawing); drawn at that shape, with gravity and
    the motors holding, the dynamics keeps every node within 1e-9 m and the kinetic energy
    below 1e-15 J for 1 s, and its cable tensions at t = 0 equal the statics' to 1e-9 N."""
    d = spine()
    robot = robot_from_dict(d)
    l0 = robot.cables.rest_length.copy()
    driven = np.array([n.startswith("sidexp") for n in robot.cables.names])
    l0[driven] *= 0.97
    shape = rest_shape(robot, l0, gravity=True)
    assert shape.stable and np.abs(shape.nodes - robot.nodes).max() > 0.01
    d["nodes"] = {n: xyz for n, xyz in zip(robot.node_names, shape.nodes.tolist())}
    for cable, rest in zip(d["cables"], l0):
        cable["rest_length"] = float(rest)
    run = simulate(load_scene({"name": "spine_at_its_rest_shape", "model": {"kind": "robot", "robot": d},
                               "initial": {"drawn": True}, "effects": ["inertia", "cables", "gravity"],
                               "duration": 1.0, "output": {"rate": 100}}))
    assert np.abs(run.nodes - shape.nodes).max() < 1e-9
    assert run.kinetic_energy.max() < 1e-15
    cables = slice(len(robot.rods), None)
    np.testing.assert_allclose(run.member_forces[0, cables], shape.member_forces[cables], rtol=0, atol=1e-9)
