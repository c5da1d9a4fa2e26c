"""An exported robot's IMU sensors read what the project's IMU reads: the same orientation,
angular velocity and specific force, in the same frame (the project's rod frame, whose axes
are the world's in the drawing; docs/ros.md, ``imu/<rod>``).

The run: the 3-bar without gravity or floor, two motors reeling in (td_0 to 0.40 m, td_3 to
0.45 m through the motors' 1 s lag), 1 s, in the project (RK4 at ``max_step``) and in MuJoCo
(RK4 at the same step, ``ctrl`` = the same targets). The two integrate the same equations but
for one thing: the project holds a motor's rest length over each step (sampled, updated at its
end) and MuJoCo's activation moves within it, a force difference of ``k dl0/dt h / 2`` -- first
order in the step ``h``. So the readings of the two differ by an amount that halves with the
step (measured: 0.058, 0.028, 0.014 m/s^2 and 2.4e-5, 1.2e-5, 6e-6 rad at 1, 0.5, 0.25 ms);
an IMU read in another frame differs by a turn that does not (2.9 rad with the rod's principal
axes).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from tensegrity_core.export import export_mjcf
from tensegrity_core.sim import compile_scene, load_scene
from tests.mujoco_peer import touching_caps

INPUTS = {"td_0": 0.40, "td_3": 0.45}           # m, rest-length targets
IMUS = ("r01", "r23")                           # the 3-bar's IMUs (three_bar.yaml)
T_END, SAMPLE = 1.0, 0.01                       # s


def differences(h: float) -> np.ndarray:
    """Largest |specific force| [m/s^2], |angular velocity| [rad/s] and orientation [rad]
    difference between MuJoCo's IMU sensors and the project's readings over the run at step ``h``."""
    import mujoco

    scene = load_scene({"name": "three_bar_reeling", "model": {"kind": "robot", "robot": "three_bar"},
                        "initial": {"drawn": True}, "inputs": INPUTS,
                        "effects": ["inertia", "cables", "motors", "sensors"],
                        "integrator": {"max_step": h}, "duration": T_END})
    times = np.arange(round(T_END / SAMPLE) + 1) * SAMPLE
    model = compile_scene(scene)
    samples: list = []
    model.record(model.initial_state(t_end=T_END), times, samples)
    o = model.observe(samples)
    m = mujoco.MjModel.from_xml_string(export_mjcf(scene).xml)
    assert m.opt.timestep == h and m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    for name, u in INPUTS.items():
        d.ctrl[m.actuator(f"cable:{name}").id] = u
    worst = np.zeros(3)
    for k in range(len(times)):
        mujoco.mj_forward(m, d)
        mujoco.mj_rnePostConstraint(m, d)           # the accelerometer's reading at this state
        for i, imu in enumerate(IMUS):
            w, x, y, z = d.sensor(f"imu:{imu}:orientation").data
            turn = (Rotation.from_quat([x, y, z, w]).inv() * Rotation.from_quat(o["imu_orientation"][k][i])).magnitude()
            worst = np.maximum(worst, [
                np.linalg.norm(d.sensor(f"imu:{imu}:accelerometer").data - o["imu_specific_force"][k][i]),
                np.linalg.norm(d.sensor(f"imu:{imu}:gyro").data - o["imu_angular_velocity"][k][i]),
                turn])
        if k < len(times) - 1:
            mujoco.mj_step(m, d, nstep=round(SAMPLE / h))
    return worst


def test_the_exported_imus_read_the_projects_readings_in_its_frame():
    coarse, fine = differences(1e-3), differences(5e-4)
    # first order in the step: halved (0.6 leaves room for the next order), in every reading
    assert np.all(fine <= 0.6 * coarse), (coarse, fine)
    # and small where it starts: the rods agree to 2.3e-5 m at 1 ms, over half-lengths of 0.6 m
    assert coarse[2] < 1e-3, coarse


def test_after_landing_the_rod_axis_agrees_and_the_spin_about_it_is_the_contacts_choice():
    """``three_bar_drop`` (3 s): rod r01's IMU orientation in the project and in MuJoCo, split
    into the tilt of the rod's axis from the vertical and the rest. Both robots rest on the same
    three caps (``test_robot_mujoco.py::test_the_projects_drop_and_mujocos_rest_on_the_same_face``)
    with the same net (the same cables, motors holding), so one pose is the other slid along the
    floor and turned about the vertical, up to the caps' sinking (each below 1 mm, agreeing
    within 10 %): the plane of the three caps, and every rod's tilt in it, differ by at most
    ``2 mm / d`` for ``d`` the shortest distance between the caps. The turn about the vertical
    and the spin about the rod's own axis (which no cable resists: the cables pull at its cap
    centres, on the axis) are what the two contact models' friction decides, and differ
    (docs/mujoco.md): measured 0.35 rad of the orientation's 0.35 rad difference is spin."""
    import mujoco

    scene = load_scene("three_bar_drop")
    robot = scene.model.robot
    t_end = float(scene.duration)
    model = compile_scene(scene)
    samples: list = []
    model.record(model.initial_state(t_end=t_end), np.array([0.0, t_end]), samples)
    project = Rotation.from_quat(model.observe(samples)["imu_orientation"][-1][IMUS.index("r01")])
    m = mujoco.MjModel.from_xml_string(export_mjcf(scene).xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    mujoco.mj_step(m, d, nstep=round(t_end / m.opt.timestep))
    mujoco.mj_forward(m, d)
    w, x, y, z = d.sensor("imu:r01:orientation").data
    peer = Rotation.from_quat([x, y, z, w])
    s0, s1 = (robot.nodes[robot.node_names.index(n)] for n in ("s0", "s1"))
    axis = (s1 - s0) / np.linalg.norm(s1 - s0)          # in the IMU's frame: the world's axes as drawn
    tilt = abs(np.arccos(project.apply(axis)[2]) - np.arccos(peer.apply(axis)[2]))   # rad, from the vertical
    caps = [d.site(f"node:{n}").xpos for n in touching_caps(m, d, min_force=0.02 * robot.total_mass() * 9.81)]
    assert len(caps) == 3
    shortest = min(np.linalg.norm(a - b) for i, a in enumerate(caps) for b in caps[i + 1:])
    difference = (peer.inv() * project).magnitude()
    assert tilt <= 2e-3 / shortest < difference, (tilt, 2e-3 / shortest, difference)
