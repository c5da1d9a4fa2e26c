"""The ``tensegrity formfind`` and ``tensegrity modes`` commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from tensegrity_core.general import example_path, form_find, load_example
from tensegrity_ros.cli import main


def test_formfind_writes_yaml_and_json_results_and_a_plot(tmp_path, capsys):
    out_yaml, out_json, png = tmp_path / "r.yaml", tmp_path / "r.json", tmp_path / "shape.png"
    assert main(["formfind", str(example_path("patio_shade")), "-o", str(out_yaml), "--plot", str(png)]) == 0
    printed = capsys.readouterr()
    assert "converged to a stable equilibrium" in printed.out and "s1" in printed.out
    assert "(relative; norm " in printed.out and "stability margin " in printed.out
    assert main(["formfind", "patio_shade", "-o", str(out_json), "--quiet"]) == 0
    a, b = yaml.safe_load(out_yaml.read_text()), json.loads(out_json.read_text())
    assert a == b
    assert a["residual"] <= 1e-10 and 0 <= a["residual_norm"] <= 1e-10 * 7.6e6 and a["stability_margin"] > 1
    ref = form_find(load_example("patio_shade"))
    np.testing.assert_allclose(np.array(list(a["nodes"].values())), ref.nodes, atol=1e-12)
    np.testing.assert_allclose([m["force"] for m in a["members"].values()], ref.member_forces, rtol=1e-12)
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name, residual, eigenvalue", [("t_bar", "N", "N/m"),
                                                       ("tensegrity_table", "N, N m", "N/m and N m/rad mixed")])
def test_the_summary_gives_the_units_of_the_residual_and_the_eigenvalue(capsys, name, residual, eigenvalue):
    """With rigid bodies the residual holds moments and K_T their rotations: the units say so."""
    assert main(["formfind", name, "--quiet"]) == 0
    out = capsys.readouterr().out
    assert f" {residual}), min eigenvalue of K_T [{eigenvalue}] " in out, out


def test_formfind_json_on_stdout_and_progress_on_stderr(capsys):
    assert main(["formfind", "spine_c", "--json"]) == 0
    out = capsys.readouterr()
    data = json.loads(out.out)
    assert data["success"] and data["iterations"] > 1 and len(data["members"]) == 72


def test_progress_line_shows_residual_and_shift(capsys):
    assert main(["formfind", "spine_s"]) == 0
    err = capsys.readouterr().err
    assert "residual" in err and "shift" in err and " N), step " in err


def test_failure_exits_non_zero_with_one_line(tmp_path, capsys):
    bad = tmp_path / "neutral.yaml"
    bad.write_text("nodes: {a: [-1,0,0], b: [0,0,0], c: [1,0,0]}\n"
                   "members: [{nodes: [a, b], EA: 1}, {nodes: [b, c], EA: 1}]\npinned: [a, c]\n")
    assert main(["formfind", str(bad), "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("error: form-finding failed: converged to an equilibrium with an unstiffened")
    assert len([line for line in err if line.startswith("error:")]) == 1


def test_a_failed_form_finding_prints_no_nan(capsys):
    """Stopped before any iteration there is no equilibrium and no stability check: the
    summary says so instead of printing 'nan' (the JSON gives null)."""
    assert main(["formfind", "tensegrity_table", "--max-iter", "0"]) == 1
    out = capsys.readouterr().out
    assert "stability not checked" in out and "nan" not in out.lower()


@pytest.mark.parametrize("args, message", [
    (["formfind", "no_such_file.yaml"], "structure file not found"),
    (["formfind", "patio_shade", "-o", "result.txt"], "must end in .yaml"),
    (["formfind", "patio_shade", "--method", "magic"], "unknown form-finding method"),
    (["modes", "patio_shade", "--stiffness", "-1"], "--stiffness must be >= 0 (the number of eigenvalues to print), got -1"),
])
def test_bad_input_is_one_error_line_with_code_2(args, message, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("error: ") and message in err[-1]


def test_bad_yaml_reports_the_line(tmp_path, capsys):
    f = tmp_path / "bad.yaml"
    f.write_text("nodes:\n  a: [0, 0, 0]\n  b: [1, 0, 0]\nmembers:\n  - {nodes: [a, q], EA: 1}\n")
    assert main(["formfind", str(f)]) == 2
    assert "bad.yaml: member 'm0': unknown node 'q' (line 5)" in capsys.readouterr().err


def test_modes_command(capsys):
    assert main(["modes", "patio_shade", "--at-equilibrium", "--json", "--stiffness", "3"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["rank"], data["self_stress_modes"], data["mechanism_modes"]) == (4, 1, 5)
    np.testing.assert_allclose(list(data["self_stress"][0].values()),
                               [0.4678, 0.4514, 0.4725, 0.4166, 0.4250], atol=1.5e-4)
    assert len(data["stiffness_eigenvalues"]) == 3 and min(data["stiffness_eigenvalues"]) > 0
    assert main(["modes", "tensegrity_table"]) == 0
    assert "1 self-stress mode(s)" in capsys.readouterr().out
