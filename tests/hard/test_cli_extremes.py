"""``tensegrity simulate`` and ``tensegrity formfind`` at the extremes (issue 12): every
extreme value and every hostile file is refused by name in one ``error:`` line with a
non-zero exit, no traceback, no numpy warning and no huge allocation.

All cases run in one child process whose address space is capped at 3 GiB, so a command
that tried to allocate a 37 GiB output (as ``output.rate: 1e9`` once did) fails the test
instead of the machine.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tensegrity_core.general import example_path
from tensegrity_core.sim import scene_path

DRIVER = textwrap.dedent("""\
    import contextlib, io, json, resource, sys, traceback, warnings
    resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))
    from tensegrity_ros.cli import main
    out = []
    for args in json.loads(sys.argv[1]):
        err, std = io.StringIO(), io.StringIO()
        with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stderr(err), \\
                contextlib.redirect_stdout(std):
            warnings.simplefilter("always")
            try:
                rc, crash = main(args), ""
            except BaseException:
                rc, crash = None, traceback.format_exc(limit=2)
        out.append({"rc": rc, "stderr": err.getvalue(), "stdout": std.getvalue(), "crash": crash[-400:],
                    "warnings": [str(w.message)[:200] for w in caught]})
    print(json.dumps(out))
    """)


def _bomb(key: str) -> str:
    """About 340 bytes that stand for 9**8 = 43 million values under ``key``."""
    names = "abcdefgh"
    parts = ["&a [" + ",".join(["lol"] * 9) + "]"]
    parts += [f"&{names[k]} [" + ",".join([f"*{names[k - 1]}"] * 9) + "]" for k in range(1, 8)]
    return f"{key}: [{', '.join(parts)}, *h]\n"


def _cases(tmp: Path) -> list[tuple[list[str], str]]:
    fold = scene_path("paper_fold").read_text()
    table = example_path("tensegrity_table").read_text()
    files = {
        "L.yaml": fold.replace("L: 1.0", "L: 1.0e300"),
        "duration.yaml": fold.replace("duration: 5.0", "duration: 1.0e300"),
        "rate.yaml": fold.replace("rate: 100", "rate: 1.0e9"),
        "bomb_scene.yaml": _bomb("description"),
        "deep_scene.yaml": "model:\n  kind: " + "[" * 100_000 + "]" * 100_000 + "\n",
        "EA.yaml": table.replace("E: 7.6e+10, A: 1.0e-4", "EA: 1.0e308"),
        "coords.yaml": table.replace("c1: [0.0, 1.0, 1.0]", "c1: [1.0e300, 1.0, 1.0]"),
        "bomb_structure.yaml": _bomb("name"),
        "deep_structure.yaml": "nodes:\n" + "".join("  " * (i + 1) + f"k{i}:\n" for i in range(2000)),
        "int.yaml": table.replace("rest_length_ratio: 0.3}", "rest_length_ratio: 0.3, mass: 1" + "0" * 5000 + "}"),
    }
    originals = (fold, table)
    assert not any(text in originals for text in files.values()), "a case's replacement found nothing to replace"
    for name, text in files.items():
        (tmp / name).write_text(text)
    (tmp / "latin1_scene.yaml").write_bytes(b"name: caf\xe9\n" + fold.encode())
    (tmp / "latin1_structure.yaml").write_bytes(b"name: caf\xe9\n" + table.encode())
    sim, ff = ["simulate", "--quiet"], ["formfind", "--quiet"]
    return [
        (sim + [str(tmp / "L.yaml")], "model.params.L: must be at most 1e+15 m in magnitude, got 1e+300 m"),
        (sim + [str(tmp / "duration.yaml")], "duration: must be at most 1e+15 s in magnitude, got 1e+300 s"),
        (sim + ["paper_fold", "--duration", "1e300"], "duration: must be at most 1e+15 s in magnitude"),
        (sim + [str(tmp / "rate.yaml")], "output.rate: duration x output.rate = 5 s x 1e+09 Hz gives 5e+09 samples"),
        (sim + [str(tmp / "latin1_scene.yaml")], "latin1_scene.yaml: not UTF-8 text: byte 0xe9 at offset 9 (line 1)"),
        (sim + [str(tmp / "bomb_scene.yaml")], "aliases expand to more than 10000 values"),
        (sim + [str(tmp / "deep_scene.yaml")], "deep_scene.yaml: invalid YAML: exceeded maximum nesting depth"),
        (ff + [str(tmp / "EA.yaml")], "defaults: EA must be at most 1e+15 N in magnitude, got 1e+308 N"),
        (ff + [str(tmp / "coords.yaml")], "coordinates of node 'c1' must be at most 1e+15 m in magnitude, got 1e+300 m"),
        (ff + [str(tmp / "latin1_structure.yaml")], "not UTF-8 text: byte 0xe9 at offset 9 (line 1)"),
        (ff + [str(tmp / "bomb_structure.yaml")], "aliases expand to more than 10000 values"),
        (ff + [str(tmp / "deep_structure.yaml")], "nested deeper than 64 levels"),
        (ff + [str(tmp / "int.yaml")], "has too many digits"),
        (ff + ["x" * 70_000], "no structure file or shipped example 'xxxxx"),
        (["call-formfind", str(tmp / "latin1_structure.yaml")], "not UTF-8 text: byte 0xe9 at offset 9 (line 1)"),
    ]


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("extremes")
    cases = _cases(tmp)
    run = subprocess.run([sys.executable, "-c", DRIVER, json.dumps([args for args, _ in cases])],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    return list(zip(cases, json.loads(run.stdout.splitlines()[-1])))


@pytest.mark.parametrize("index", range(15))
def test_an_extreme_value_is_one_error_line(outcomes, index):
    (args, words), got = outcomes[index]
    assert not got["crash"], got["crash"]
    assert got["rc"] == 2, got
    assert not got["warnings"], got["warnings"]
    lines = got["stderr"].splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and len(lines[0]) < 400, got["stderr"][:1000]
    assert words in lines[0], lines[0]
    assert got["stdout"] == ""
