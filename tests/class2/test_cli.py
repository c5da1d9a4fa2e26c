"""The class-2 subcommands of the ``tensegrity`` CLI, run as a user runs them."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from tensegrity_ros.cli import main

EXE = Path(sys.executable).with_name("tensegrity")


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(EXE), *args], capture_output=True, text=True, timeout=120)


def test_fk_json_subprocess_matches_the_paper_and_derivation():
    out = run("fk", "0.7", "0.7", "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["beta"] == pytest.approx(math.atan2(math.sqrt(4 - 1.4**2), 1.4), abs=1e-15)
    assert data["beta"] == pytest.approx(0.8, abs=0.005)            # Sect. 5.3
    assert data["x"] == pytest.approx(1.4) and data["stable"] and data["in_paper_range"]
    assert set(data) >= {"rho1", "rho2", "beta", "alpha", "x", "y", "stable", "in_paper_range", "nodes"}


def test_out_of_domain_exits_non_zero_with_one_line_reason_subprocess():
    out = run("fk", "1.2", "0.1")
    assert out.returncode != 0
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "rho1" in lines[0]
    out = run("ik", "3", "0.5", "--json")
    assert out.returncode != 0
    assert out.stderr.strip().splitlines() == ["error: no valid solution for D = (3, 0.5) m: outside the workspace by 1.06 m"]
    assert json.loads(out.stdout)["solutions"] == []


def test_an_unknown_option_gets_the_commands_usage_and_the_closest_option_subprocess():
    out = run("fk", "0.7", "0.7", "--jsn")
    assert out.returncode == 2 and out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert lines[0].startswith("usage: tensegrity fk ")
    assert lines[-1] == "tensegrity fk: error: unrecognized arguments: --jsn (did you mean --json?)"


def test_workspace_plot_subprocess(tmp_path):
    png = tmp_path / "ws.png"
    out = run("workspace", "--plot", str(png), "--rho1-range", "0.2", "0.8", "--rho2-range", "0", "0.3")
    assert out.returncode == 0, out.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "area =" in out.stdout


def test_fk_human_readable_note_outside_the_paper_range(capsys):
    assert main(["fk", "0.9", "0.1"]) == 0
    text = capsys.readouterr().out
    # the minimum of U(beta) = const + (a cos beta + b sin beta) L/2 (Eq. 9 at locked actuators,
    # k = L = 1): a = rho1 - 3 rho2 = 0.6, b = -lambda1 = -sqrt(4 - (rho1 + rho2)^2); (cos, sin) || -(a, b)
    minimum = math.atan2(math.sqrt(4 - (0.9 + 0.1) ** 2), -(0.9 - 3 * 0.1))
    assert "no stable equilibrium in the paper's range [0, pi/2]" in text and f"beta = {minimum:.6g} rad" in text


def test_fk_numeric_and_param_override(capsys):
    assert main(["fk", "0.5", "0.5", "--param", "k=2", "--param", "L=1.5", "--numeric", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["params"]["k3"] == 2.0 and data["params"]["L"] == 1.5
    # with k2 = k3 and rho1 = rho2: tan(beta) = lambda1 / (2 rho) = tan(alpha)
    assert data["beta"] == pytest.approx(data["alpha"], abs=1e-10)


def test_ik_all_lists_every_candidate_with_reasons(capsys):
    assert main(["ik", "1.4", "0.7141428428542851", "--all", "--json"]) == 0
    sols = json.loads(capsys.readouterr().out)["solutions"]
    assert [s["valid"] for s in sols] == [True, False]
    assert sols[0]["rho1"] == pytest.approx(0.7) and sols[0]["rho2"] == pytest.approx(0.7)
    assert "negative length rho2" in sols[1]["reason"] and "spurious" in sols[1]["reason"]


def test_ik_seed_orders_branches_nearest_first(capsys):
    args = ["ik", "0.5726731646460115", "0.944911182523068", "--no-paper-range", "--json"]
    assert main(args + ["--seed", "0.85", "0.15"]) == 0
    first = json.loads(capsys.readouterr().out)["solutions"][0]
    assert (first["delta1"], first["delta2"]) == (1, -1) and not first["in_paper_range"]
    assert main(args + ["--seed", "0.2", "0.3"]) == 0
    first = json.loads(capsys.readouterr().out)["solutions"][0]
    assert first["delta1"] == -1 and first["in_paper_range"]


def test_stiffness_single_and_sweep_with_plot(capsys, tmp_path):
    assert main(["stiffness", "0.7", "0.7", "--f", "1", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["K_i"]) == {"Bx", "Cx", "Dx", "Dy", "Ex", "Ey", "Fy"}
    assert data["equilibrium_residual"] < 1e-12
    png = tmp_path / "fig2.png"
    assert main(["stiffness", "0.7", "0.7", "--sweep", "0", "5", "--points", "5", "--plot", str(png)]) == 0
    assert "K4 Dy" in capsys.readouterr().out and png.stat().st_size > 10_000


def test_stiffness_says_when_k_is_not_positive_definite(capsys):
    """Springs of 100 N/m against actuators of 10 N/m near the fold: every K_i is positive but
    K has a negative eigenvalue (-72.48 N/m by an independent Hessian, tests/class2/test_stiffness.py)."""
    assert main(["stiffness", "0.05", "0.05", "--param", "k=100"]) == 0
    out = capsys.readouterr().out
    assert "smallest eigenvalue of K = -72.4787 N/m: K is not positive definite" in out
    assert main(["stiffness", "0.7", "0.7"]) == 0
    assert "smallest eigenvalue of K = 0.744099 N/m (positive definite)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["stiffness", "0", "0.5"], "zero length"),
        (["stiffness", "0.5", "0.5", "--sweep", "3", "1"], "FMIN < FMAX"),
        (["stiffness", "0.5", "0.5", "--plot", "x.png"], "--plot needs --sweep"),
        (["workspace", "--rho1-range", "2", "3"], "does not meet"),
        (["fk", "0.5", "nan"], "finite"),
        (["fk", "0.5", "0.5", "--param", "kb=-1"], "kb must be > 0"),
        (["singularities", "0.5", "1.6"], "exceeds 2L"),
        (["ik", "1.4", "0.7", "--seed", "nan", "0.7"], "seed rho1 must be finite, got nan"),
        (["ik", "1.4", "0.7", "--seed", "0.7", "inf"], "seed rho2 must be finite, got inf"),
        (["ik", "1.4", "0.7", "--param", "k=1e-300"], "k1 must be between 1e-15 N/m and 1e+15 N/m"),
        (["stiffness", "0.7", "0.7", "--sweep", "0", "5", "--points", "100000000"],
         "--points must be between 2 and 10000, got 100000000"),
        (["workspace", "--points", "1000000000"], "--points must be between 2 and 10000, got 1000000000"),
    ],
)
def test_bad_input_one_line_errors(argv, fragment, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and fragment in err[0]


def test_singularities_table_gives_each_value_its_unit(capsys):
    """Every number of the table's value column carries its unit: rad for the angles, m/m for
    det dD/drho, N^4 m^2 for the IK discriminant (stiffnesses in N/m), a multiple of L or 2L
    for the lengths (lambda2 = sqrt(L^2 - rho1^2) = 0.8 L at rho1 = 0.6 m, L = 1 m)."""
    assert main(["singularities", "0.6", "0.3"]) == 0
    rows = {line.split()[0]: line.split()[2:] for line in capsys.readouterr().out.splitlines()[2:]}
    units = {kind: words[1] if words[1] != "x" else " ".join(words[1:3]) for kind, words in rows.items()}
    assert units == {"lambda1": "x 2L", "beta_zero": "rad", "lambda2": "x L", "beta_half_pi": "rad",
                     "ik_discriminant": "N^4", "det_jacobian": "m/m", "folded": "x L"}
    assert rows["ik_discriminant"][2] == "m^2"
    assert float(rows["lambda2"][0]) == pytest.approx(0.8)
    assert float(rows["folded"][0]) == pytest.approx(math.hypot(0.6, 0.3))


def test_singularities_table(capsys):
    assert main(["singularities", "0.6", "0.2", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["sets"][0]["kind"] in {"beta_half_pi", "ik_discriminant", "det_jacobian"}
    assert data["sets"][0]["distance"] < 1e-15
