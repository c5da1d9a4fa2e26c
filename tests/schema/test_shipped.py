"""Description files shipped as package data: names, paths and the message for an unknown name."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

import tensegrity_core
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


def _numbers_read_as_text(value, where=""):
    """Paths of the strings in a parsed document that mean a number (``'7.6e10'``)."""
    if isinstance(value, dict):
        return [p for k, v in value.items() for p in _numbers_read_as_text(v, f"{where}/{k}")]
    if isinstance(value, list):
        return [p for i, v in enumerate(value) for p in _numbers_read_as_text(v, f"{where}/{i}")]
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return []
        return [f"{where} = {value!r}"]
    return []


def test_a_plain_yaml_parser_reads_every_shipped_number_as_a_number():
    # The project's reader takes 7.6e10 as the number it means; PyYAML's YAML 1.1 resolver reads
    # it as text (its float pattern wants a '.' and a signed exponent), so a user's own script
    # would see strings. Shipped files write numbers every YAML 1.1 reader takes (7.6e+10).
    root = Path(tensegrity_core.__file__).parent
    bad = [f"{path.relative_to(root)}: {p}" for path in sorted(root.rglob("*.yaml"))
           for p in _numbers_read_as_text(yaml.safe_load(path.read_text()))]
    assert not bad, "\n".join(bad)
