"""``tensegrity simulate`` and ``tensegrity scenes``; trajectory files."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from tensegrity_core.sim import Trajectory, scene_names, simulate
from tensegrity_ros.cli import main

SHORT = {"paper_fold": 0.2, "paper_fold_quasistatic": 0.2, "stiff_fold": 0.2, "class2_at_rest": 0.2,
         "table_gravity": 0.005, "spine_release": 0.02, "three_bar_drop": 0.02, "six_bar_drop": 0.02,
         "spine_settle": 0.02, "six_bar_roll": 0.02, "three_bar_crawl": 0.02,
         "table_actuated": 0.05, "spine_bend": 0.02, "six_bar_rest": 0.02,
         "six_bar_roll_closed_loop": 0.02}


def read_csv(path) -> np.ndarray:
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")][1:]
    return np.array([[float(v) for v in row.split(",")] for row in rows])


@pytest.mark.parametrize("name", sorted(SHORT))
def test_every_shipped_scene_runs_from_the_cli(name, tmp_path, capsys):
    out, plot = tmp_path / f"{name}.npz", tmp_path / f"{name}.png"
    code = main(["simulate", name, "--duration", str(SHORT[name]), "-o", str(out), "--plot", str(plot), "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == 0 and summary["success"] and summary["scene"] == name
    assert summary["t_end"] == pytest.approx(SHORT[name]) and plot.stat().st_size > 10_000
    traj = Trajectory.from_npz(out)
    assert len(traj) == summary["samples"] and np.all(np.isfinite(traj.states))


def test_all_shipped_scenes_are_covered():
    assert set(SHORT) == set(scene_names())


def test_the_scenes_command_lists_them(capsys):
    assert main(["scenes", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["name"] for r in rows} == set(scene_names())
    assert main(["scenes"]) == 0
    assert "paper_fold_quasistatic" in capsys.readouterr().out


def test_scene_errors_are_one_line_with_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(textwrap.dedent("""\
        model: {kind: class2}
        initial: {q: [0.5, 0.5, 1.0]}
        inputs: {f1: 0.0, f2: 0.0}
        effects: [inertia, springs, dampin]
        duration: 1.0
        """))
    assert main(["simulate", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: bad.yaml: effects[2]: unknown effect 'dampin'")
    assert err[0].endswith("(line 4)")
    assert main(["simulate", "paper_fold", "-o", str(tmp_path / "x.txt")]) == 2
    capsys.readouterr()
    assert main(["simulate", "paper_fld"]) == 2
    assert "neither a shipped scene (did you mean 'paper_fold'?)" in capsys.readouterr().err
    assert main(["simulate", "no_such_scene"]) == 2
    assert main(["simulate", "paper_fold", "--duration", "-1"]) == 2


def test_a_run_that_stops_early_writes_what_it_has_and_exits_1(tmp_path, capsys):
    scene = tmp_path / "push.yaml"
    scene.write_text(textwrap.dedent("""\
        model: {kind: class2}
        initial: {equilibrium: {rho1: 0.7, rho2: 0.7}}
        inputs: {f1: -20.0, f2: -20.0}
        effects: [inertia, springs]
        duration: 5.0
        """))
    out = tmp_path / "push.csv"
    assert main(["simulate", str(scene), "-o", str(out), "--quiet"]) == 1
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines()[-1].startswith("error: simulation stopped early: t = ")
    table = read_csv(out)
    assert 0 < len(table) < 501


def test_ctrl_c_writes_what_was_computed_and_says_so(tmp_path):
    """Ctrl-C ends the run at its next sample: the samples computed so far are written and
    plotted, the last line says where, exit code 130 (SIGTERM has the same handler)."""
    import signal
    import time

    from tests.process_groups import exited, kill_group

    out, plot = tmp_path / "run.npz", tmp_path / "run.png"
    proc = subprocess.Popen([sys.executable, "-m", "tensegrity_ros.cli", "simulate", "table_gravity", "--duration",
                             "20", "-o", str(out), "--plot", str(plot)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, env=dict(os.environ))
    try:
        deadline = time.monotonic() + 300          # a guard against a hang, not a timing
        progress = b""
        while not re.search(rb"\| 0*[.0-9]*[1-9][.0-9]*/20 s", progress):   # the bar has moved: the run is on
            assert not exited(proc) and time.monotonic() < deadline, "no progress"
            progress += os.read(proc.stderr.fileno(), 4096)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        kill_group(proc)
    assert proc.returncode == 130, stderr
    traj = Trajectory.from_npz(out)
    t_end = float(traj.times[-1])
    assert 0 < t_end < 20.0 and plot.stat().st_size > 10_000
    assert stderr.strip().splitlines()[-1] == (f"interrupted at t = {t_end:.6g} s: the run up to there is written "
                                               f"to {out} and plotted in {plot}")
    assert "Traceback" not in stderr and f"interrupted at t = {t_end:.6g} s:" in stdout


def test_csv_and_npz_hold_the_same_run(tmp_path):
    traj = simulate("paper_fold", duration=2.0)
    traj.to_csv(tmp_path / "t.csv")
    traj.to_npz(tmp_path / "t.npz")
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert lines[0] == "# scene: paper_fold" and any(line.startswith("# event: t=1.38") for line in lines)
    header = next(line for line in lines if not line.startswith("#")).split(",")
    table = read_csv(tmp_path / "t.csv")
    cols, expected = traj.csv_columns()
    assert header == cols and header[:4] == ["t", "rho1", "rho2", "beta"] and "force_AE" in header
    np.testing.assert_array_equal(table, expected)
    back = Trajectory.from_npz(tmp_path / "t.npz")
    for name in ("times", "states", "member_forces", "end_effector", "applied_forces", "folded"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.events == [tuple(e) for e in traj.events] and back.scene == traj.scene


def test_the_console_script_runs():
    env = dict(os.environ, MPLBACKEND="Agg")
    exe = os.path.join(os.path.dirname(sys.executable), "tensegrity")
    result = subprocess.run([exe, "simulate", "paper_fold", "--duration", "0.5"], capture_output=True, text=True,
                            env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "scene paper_fold" in result.stdout and "simulated 0.5 s" in result.stdout


@pytest.mark.parametrize("name, q_units", [("paper_fold", "rho1 [m], rho2 [m], beta [rad]"),
                                           ("table_gravity", "[m]"), ("three_bar_drop", "[rad]")])
def test_the_printed_summary_gives_every_number_its_unit(name, q_units, capsys):
    assert main(["simulate", name, "--duration", str(SHORT[name])]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^final q \(.*" + re.escape(q_units) + r".*\) = \[", out, re.M), out
    assert re.search(r"^final end effector \[m\] = \[", out, re.M), out
    step = re.search(r"\bstep (\S+)( s)?[,)]", out)
    assert step is None or step.group(2) == " s", out
