"""A Ctrl-C that a library turned into an error of its own ends a sweep as a Ctrl-C: never a
failure of the base, never an error row."""

from __future__ import annotations

import pytest

from tests.test_interrupts import pybind11_import_interrupted


@pytest.mark.parametrize("where", ["probe", "run"])
def test_a_ctrl_c_turned_into_an_import_error_ends_the_sweep_as_a_ctrl_c(tmp_path, monkeypatch, capsys, where):
    """While the base is computed (``probe``) the command ends with exit code 130 and its one
    interrupted line, not a "base cannot be computed" error; while a point runs in this
    process (``--workers 0``) the sweep ends there, and the point is not an error row."""
    import json

    from tensegrity_core.sweep import run_sweep
    from tensegrity_core.sweep.computations.simulate import Simulate
    from tensegrity_ros.cli import main
    from tests.sweep.conftest import fold_sweep

    sweep = tmp_path / "s.json"
    sweep.write_text(json.dumps(fold_sweep()))
    monkeypatch.setattr(Simulate, where, pybind11_import_interrupted)
    if where == "run":
        with pytest.raises(KeyboardInterrupt):
            run_sweep(str(sweep), workers=0, progress=False)
    code = main(["sweep", str(sweep), "-o", str(tmp_path / "r.parquet"), "--workers", "0", "--quiet"])
    err = capsys.readouterr().err
    assert code == 130, err
    assert err.strip().splitlines() == ["interrupted before the first point finished: nothing written"]
