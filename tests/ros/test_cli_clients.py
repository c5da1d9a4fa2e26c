"""The client commands users run without the ros2 CLI: call-ik, send-forces, echo (issue 6)."""

from __future__ import annotations

import json
import math

import pytest

from tests.ros_support import run_cli

pytestmark = pytest.mark.ros


def test_call_ik_json_reaches_the_target(cli):
    ik = cli("node", "ik", log_name="ik")
    ik.wait_for("solve_ik ready")
    # D for rho = (0.5, 0.6) from the energy-minimising beta (paper parameters)
    beta = math.atan2(math.sqrt(4 - 1.1**2), 3 * 0.6 - 0.5)
    x, y = 0.5 + math.cos(beta), math.sin(beta)
    out = run_cli("call-ik", f"{x!r}", f"{y!r}", "--json", timeout=60)
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["success"] and len(data["solutions"]) == 1
    s = data["solutions"][0]
    assert (s["rho1"], s["rho2"]) == pytest.approx((0.5, 0.6), abs=1e-10)
    bad = run_cli("call-ik", "5", "5", timeout=60)
    assert bad.returncode == 1 and bad.stdout.startswith("failed:")


def test_send_forces_then_echo_shows_them_applied(cli):
    sim = cli("node", "sim", "--ros-args", "-p", "command_timeout:=0.0", log_name="sim")
    sim.wait_for("publishing at")
    out = run_cli("send-forces", "0.5", "-0.2", timeout=60)
    assert out.returncode == 0, out.stderr
    echo = run_cli("echo", "joint_states", "-c", "1", "--json", "--timeout", "30", timeout=60)
    assert echo.returncode == 0, echo.stderr
    msg = json.loads(echo.stdout.splitlines()[0])
    assert msg["name"] == ["rho1", "rho2", "beta"]
    assert msg["effort"][:2] == [0.5, -0.2]


def test_service_missing_is_one_clear_line():
    out = run_cli("call-ik", "1", "1", "--service", "no_such_service", "--timeout", "1", timeout=60)
    assert out.returncode == 3
    assert out.stderr.startswith("error: service /no_such_service not available")
