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
import pytest
from scipy.spatial.transform import Rotation

mujoco = pytest.importorskip("mujoco", reason="the mujoco extra is not installed (./run setup installs it)")

from tensegrity_core.export import export_mjcf  # noqa: E402
from tensegrity_core.sim import compile_scene, load_scene  # noqa: E402

INPUTS = {"td_0": 0.40, "td_3": 0.45}           # m, rest-length targets
IMUS = ("r01", "r23")                           # the 3-bar's IMUs (three_bar.yaml)
T_END, SAMPLE = 1.0, 0.01                       # s


def differences(h: float) -> np.ndarray:
    """Largest |specific force| [m/s^2], |angular velocity| [rad/s] and orientation [rad]
    difference between MuJoCo's IMU sensors and the project's readings over the run at step ``h``."""
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
