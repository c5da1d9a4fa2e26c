"""A robot scene's MJCF starts where the project's run starts: its keyframe holds each motor's
command at t = 0 (a constant input's value), its activation the drawn rest length. Loaded and
stepped from the keyframe alone, MuJoCo follows the project's run of the scene: the 3-bar
without gravity or floor, td_0 and td_3 reeled in to 0.40 and 0.45 m through the motors' 1 s
lag (their caps move up to 0.043 m in 1 s). The two differ by the motors' sampled rest
length (first order in the step: 2.3e-5 m at 1 ms, tests/export/test_robot_imu_mujoco.py),
so the caps agree to 1e-4 m; a keyframe holding the drawn rest lengths leaves MuJoCo's robot
as drawn, 0.043 m away."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.export import export_mjcf
from tensegrity_core.sim import compile_scene, load_scene

SCENE = {"name": "three_bar_reeling", "model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
         "inputs": {"td_0": 0.40, "td_3": 0.45, "td_1": {"law": "commanded", "initial": 0.5}},
         "effects": ["inertia", "cables", "motors"], "duration": 1.0}


def test_a_robot_scenes_keyframe_holds_its_initial_commands():
    import mujoco

    scene = load_scene(SCENE)
    m = mujoco.MjModel.from_xml_string(export_mjcf(scene).xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    ctrl = {m.actuator(k).name: float(d.ctrl[k]) for k in range(m.nu)}
    drawn = 0.49354935493549357                               # three_bar.yaml's td rest length [m]
    assert ctrl["cable:td_0"] == 0.40 and ctrl["cable:td_3"] == 0.45 and ctrl["cable:td_1"] == 0.5
    assert ctrl["cable:td_2"] == pytest.approx(drawn, abs=1e-15)           # commanded, no initial: as drawn
    assert np.allclose(d.act, drawn, atol=1e-15)               # the motors start as drawn, as the project's
    model = compile_scene(scene)
    samples: list = []
    model.record(model.initial_state(t_end=1.0), np.array([0.0, 1.0]), samples)
    nodes = np.asarray(model.observe(samples)["nodes"])[-1]
    mujoco.mj_step(m, d, nstep=round(1.0 / m.opt.timestep))
    caps = np.array([d.site(f"node:s{i}").xpos for i in range(6)])
    assert np.linalg.norm(nodes - caps, axis=1).max() < 1e-4
