"""Description files shipped as package data: names, paths and the message for an unknown name."""

from __future__ import annotations

import pytest

from tensegrity_core.general import StructureError
from tensegrity_core.general.examples import example_path
from tensegrity_core.schema import SchemaError, ShippedFiles
from tensegrity_core.sim import SceneError, scene_path
from tensegrity_core.sweep import SweepError
from tensegrity_core.sweep.spec import sweep_path


def test_names_are_the_sorted_stems_of_the_yaml_files_and_a_path_is_one_of_them(tmp_path):
    for name in ("walk", "fold", "bend"):
        (tmp_path / f"{name}.yaml").write_text("{}\n")
    (tmp_path / "notes.txt").write_text("not a description\n")
    shipped = ShippedFiles(tmp_path, "move", "shipped moves", SchemaError)
    assert shipped.names() == ["bend", "fold", "walk"]
    assert shipped.path("fold") == tmp_path / "fold.yaml"
    with pytest.raises(SchemaError) as err:
        shipped.path("fodl")
    assert str(err.value) == "unknown move 'fodl' (did you mean 'fold'?); shipped moves: bend, fold, walk"
    for other in ("notes", "../fold", 3, None):          # another file, another folder, not a name
        with pytest.raises(SchemaError, match=r"^unknown move .*; shipped moves: bend, fold, walk$"):
            shipped.path(other)


@pytest.mark.parametrize("path_of, error, words", [
    (scene_path, SceneError, "unknown scene 'paper_fodl' (did you mean 'paper_fold'?); shipped scenes: "),
    (example_path, StructureError, "unknown example 'paper_fodl'; shipped examples: "),
    (sweep_path, SweepError, "unknown sweep 'paper_fodl'; shipped sweeps: "),
])
def test_each_format_names_an_unknown_shipped_file_in_its_own_words_and_error(path_of, error, words):
    with pytest.raises(error) as err:
        path_of("paper_fodl")
    assert str(err.value).startswith(words)
    with pytest.raises(error, match=r"… \(300 characters\)"):     # not the system's 'file name too long'
        path_of("x" * 300)
