"""The project installs and runs as the README promises (issue 2)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ROS_MODULES = ("rclpy", "rcl_interfaces", "tensegrity_msgs", "sensor_msgs", "std_msgs")


def _site_without_ros(tmp_path: Path) -> Path:
    """A folder exposing only the core's declared numerical dependencies: no ROS wheel."""
    import numpy

    site_packages = Path(numpy.__file__).parents[1]
    site = tmp_path / "site"
    site.mkdir()
    for name in ("numpy", "numpy.libs", "scipy", "scipy.libs", "yaml", "_yaml", "threadpoolctl.py"):
        if (site_packages / name).exists():
            (site / name).symlink_to(site_packages / name)
    (site / "tensegrity_core").symlink_to(ROOT / "tensegrity_core")
    return site


def test_core_imports_and_computes_without_any_ros_module(tmp_path):
    site = _site_without_ros(tmp_path)
    code = (
        "import sys\n"
        "import tensegrity_core, tensegrity_core.class2 as c2\n"
        "import pkgutil, importlib\n"
        "for m in pkgutil.walk_packages(tensegrity_core.__path__, 'tensegrity_core.'):\n"
        "    importlib.import_module(m.name)\n"
        f"bad = [m for m in sys.modules if m.split('.')[0] in {ROS_MODULES!r}]\n"
        "assert not bad, bad\n"
        "try:\n    import rclpy\nexcept ImportError:\n    pass\nelse:\n    raise SystemExit('rclpy importable')\n"
        "print(float(c2.potential_energy([0.7, 0.7, 0.8], c2.PAPER_PARAMS)))\n"
    )
    env = {"PATH": os.environ["PATH"], "PYTHONPATH": str(site), "PYTHONNOUSERSITE": "1"}
    out = subprocess.run([sys.executable, "-S", "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert float(out.stdout) > 0


def test_no_ros_import_anywhere_in_the_core_sources():
    for path in (ROOT / "tensegrity_core").rglob("*.py"):
        text = path.read_text()
        for mod in ROS_MODULES:
            assert f"import {mod}" not in text and f"from {mod}" not in text, (path, mod)


def test_cli_help_lists_subcommands():
    exe = Path(sys.executable).with_name("tensegrity")
    out = subprocess.run([str(exe), "--help"], capture_output=True, text=True, check=True)
    assert "usage: tensegrity" in out.stdout


def test_second_setup_rebuilds_nothing():
    out = subprocess.run([str(ROOT / "run"), "setup"], capture_output=True, text=True, check=True)
    assert "installing" not in out.stderr and "building" not in out.stderr, out.stderr


def test_ros_commands_say_what_is_missing_without_ros(tmp_path):
    """In an environment without the ROS wheels every ROS command fails with one line."""
    site = _site_without_ros(tmp_path)
    (site / "tensegrity_ros").symlink_to(ROOT / "tensegrity_ros")
    env = {"PATH": os.environ["PATH"], "PYTHONPATH": str(site), "PYTHONNOUSERSITE": "1"}
    for argv in (["node", "sim"], ["up"], ["record", "-o", str(tmp_path / "b")], ["call-ik", "1", "1"]):
        out = subprocess.run([sys.executable, "-S", "-m", "tensegrity_ros.cli", *argv], env=env,
                             capture_output=True, text=True, timeout=60)
        assert out.returncode == 3, (argv, out.stderr)
        assert out.stderr.startswith("error: ROS 2 is not available") and "Traceback" not in out.stderr
