"""The rclpy script of docs/ros.md ("Your own rclpy scripts") runs as written against the
running nodes, and what it prints is right: the forward kinematics of the printed lengths
puts D where it asked (to the 4 printed decimals)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tensegrity_core.class2 import forward_kinematics

pytestmark = pytest.mark.ros

ROS_MD = Path(__file__).resolve().parents[2] / "docs" / "ros.md"


def _example() -> str:
    section = ROS_MD.read_text().split("## Your own rclpy scripts", 1)[1]
    return section.split("```python\n", 1)[1].split("```", 1)[0]


def test_the_documented_script_runs_against_the_suite(cli, tmp_path):
    for name, ready in (("ik", "solve_ik ready"), ("sim", "publishing at")):
        cli("node", name, log_name=name).wait_for(ready)
    script = tmp_path / "my_client.py"
    script.write_text(_example())
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ), cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.splitlines()
    rho1, rho2 = (float(v) for v in re.findall(r"rho\d = ([-0-9.]+) m", lines[0]))
    fk = forward_kinematics(rho1, rho2)
    assert (fk.x, fk.y) == pytest.approx((1.45, 0.70), abs=2e-4)
    assert lines[1].startswith("now: rho1 = 0.7000 m, rho2 = 0.7000 m")     # the simulator's rest
