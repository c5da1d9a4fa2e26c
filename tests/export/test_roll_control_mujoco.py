"""The closed-loop rolling gait (:mod:`tensegrity_core.robot.roll_control`) driving the 6-bar
in MuJoCo (the export of ``six_bar_rest``): the controller sees MuJoCo's contacts and cap
positions at 50 Hz and rolls the requested faces there too, counted independently from
MuJoCo's contacts by :mod:`tensegrity_core.robot.faces` (faces rested on, and hull faces
touched at all, one edge at a time: none rolled through)."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.export import export_mjcf
from tensegrity_core.robot.faces import edge_by_edge, faces_rolled, faces_touched, faces_visited
from tensegrity_core.robot.roll_control import RollController
from tensegrity_core.sim import load_scene
from tests.mujoco_peer import touching_caps

#: The control period [s] (50 Hz).
PERIOD = 0.02


#: Each count of faces 1-4 once, the two headings alternating: every count and both headings
#: are rolled in MuJoCo, 10 faces in all instead of the 20 of every count towards each heading
#: (the cost is MuJoCo's steps, ~4.5 s simulated a face). Every count towards any heading is
#: tests/robot/test_roll_control.py's check, on the project's simulation.
CASES = [(1, (1.0, 0.0)), (2, (-1.0, -0.4)), (3, (1.0, 0.0)), (4, (-1.0, -0.4))]


@pytest.mark.parametrize(("faces", "heading"), CASES)
def test_the_controller_rolls_the_requested_faces_in_mujoco(faces, heading):
    import mujoco

    scene = load_scene("six_bar_rest")
    robot = scene.model.robot
    m = mujoco.MjModel.from_xml_string(export_mjcf(scene).xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    mujoco.mj_forward(m, d)
    act = robot.cables.actuated
    motors = np.array([m.actuator(f"cable:{robot.cables.names[j]}").id for j in act])
    index = {n: i for i, n in enumerate(robot.node_names)}
    controller = RollController(robot, faces, heading=heading)
    every = round(PERIOD / m.opt.timestep)
    times, contact, touched = [], [], []
    finish = None
    for k in range(round(20.0 / m.opt.timestep)):
        if k % every == 0:
            touching = sorted(index[c] for c in touching_caps(m, d))
            nodes = np.array([d.site(f"node:{n}").xpos for n in robot.node_names])
            d.ctrl[motors] = controller.update(d.time, touching, nodes)
            times.append(d.time)
            touched.append(touching)
            contact.append(np.isin(np.arange(len(robot.node_names)), touching))
            if finish is None and controller.done:
                finish = d.time + 1.0
            if finish is not None and d.time >= finish:
                break
        mujoco.mj_step(m, d)
    assert controller.done, controller.visited
    assert faces_rolled(faces_visited(times, np.array(contact))) == faces, controller.visited
    assert len(faces_touched(touched, controller.moves.faces)) - 1 == faces, controller.visited
    assert edge_by_edge(touched, controller.moves.faces), controller.visited
