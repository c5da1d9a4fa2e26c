"""Files and text to data (size, encoding, formats), the key-path reader's checks and
suggestions, key paths, and the one error class with key, line and file."""

from __future__ import annotations

import json
import math
import pickle

import numpy as np
import pytest

from tensegrity_core.general import StructureError
from tensegrity_core.schema import (
    MAX_MAGNITUDE,
    Limits,
    Reader,
    SchemaError,
    excerpt,
    exists,
    format_key_path,
    get_at,
    parse_key_path,
    parse_text,
    parse_yaml,
    read_file,
    resolve,
    set_in_place,
    suggest,
    with_value_at,
)
from tensegrity_core.sim import SceneError


# ------------------------------------------------------------------------------ files and text
def _read_error(path, **kw) -> SchemaError:
    with pytest.raises(SchemaError) as info:
        read_file(path, **kw)
    return info.value


def test_a_file_that_is_not_utf8_is_named_with_the_byte_and_line(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_bytes(b"name: ok\nnodes: \xff\xfe\n")
    err = _read_error(path)
    assert str(err) == "s.yaml: not UTF-8 text: byte 0xff at offset 16 (line 2)"


def test_size_is_checked_before_reading_and_while_reading(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text("a: " + "x" * 2000 + "\n")
    assert "2004 bytes, more than the limit of 1000" in str(_read_error(path, limits=Limits(max_bytes=1000)))
    # /proc files say they are empty; the bound holds while reading
    environ = _read_error("/proc/self/environ", limits=Limits(max_bytes=4), fmt="yaml")
    assert "more than 4 bytes" in str(environ)


def test_only_regular_files_are_read(tmp_path):
    assert "is not a regular file" in str(_read_error(tmp_path, fmt="yaml"))
    assert "is not a regular file" in str(_read_error("/dev/zero", fmt="yaml"))
    assert "file not found" in str(_read_error(tmp_path / "none.yaml"))
    assert "cannot tell the format" in str(_read_error(tmp_path / "x.txt"))


def test_a_scene_named_by_a_fifo_a_device_or_a_folder_is_no_regular_file_not_a_missing_one(tmp_path, monkeypatch):
    """The loaders that take a name or a path (here ``tensegrity simulate``'s) call a fifo, a
    device and a folder what they are; a shipped name wins over a folder of that name."""
    import os

    from tensegrity_core.sim import load_scene

    fifo = tmp_path / "scene.yaml"
    os.mkfifo(fifo)
    for source in (str(fifo), fifo, "/dev/zero", str(tmp_path)):
        with pytest.raises(SceneError, match="is not a regular file"):
            load_scene(source)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper_fold").mkdir()
    assert load_scene("paper_fold").name == "paper_fold"


def test_json_is_read_by_json_with_depth_and_duplicate_checks():
    assert parse_text('{"a": [1, 2.5e3], "b": "]]]]"}', "json") == {"a": [1, 2500.0], "b": "]]]]"}
    deep = '{"a": ' + "[" * 65 + "]" * 65 + "}"
    with pytest.raises(SchemaError, match="nested deeper than 64 levels"):
        parse_text(deep, "json")
    ok = '{"a": "' + "[" * 500 + '", "b": [1]}'            # brackets inside strings do not nest
    assert parse_text(ok, "json")["b"] == [1]
    with pytest.raises(SchemaError, match="duplicate key 'a'"):
        parse_text('{"a": 1, "a": 2}', "json")
    with pytest.raises(SchemaError) as info:
        parse_text('{"a": 1,\n "b": }', "json")
    assert "invalid JSON" in str(info.value) and info.value.line == 2


def test_a_guessed_format_falls_back_from_json_to_yaml():
    assert parse_text("{a: 1, b: [x]}") == {"a": 1, "b": ["x"]}            # YAML flow, not JSON
    assert parse_text('{"a": 1}') == {"a": 1}
    assert parse_text('a = [1, 2]\n[t]\nb = "x"\n') == {"a": [1, 2], "t": {"b": "x"}}


def test_a_flow_list_is_read_as_json_or_yaml_and_a_table_header_as_toml():
    """Text starting with ``[`` is TOML only when its first line is a table header: a JSON or
    YAML list was read as TOML and refused as "invalid TOML" (a find_form caller sending
    ``[1, 2, 3]`` had never written TOML)."""
    assert parse_text("[1, 2, 3]") == [1, 2, 3]                             # JSON
    assert parse_text("[a, b]\n") == ["a", "b"]                             # YAML flow
    assert parse_text("[1]") == {"1": {}}                     # one bare key: a TOML table, as TOML reads it
    assert parse_text("[t]\nb = 1\n") == {"t": {"b": 1}}                    # TOML table
    assert parse_text("[[m]]  # one\nx = 1\n") == {"m": [{"x": 1}]}         # array of tables
    assert parse_text('["a b".c]\nx = 1\n') == {"a b": {"c": {"x": 1}}}


def test_toml_errors_have_their_line():
    with pytest.raises(SchemaError) as info:
        parse_text('a = 1\nb = = 2\nc = 3\n', "toml")
    assert str(info.value).startswith("invalid TOML: ") and info.value.line == 2


def test_text_over_the_size_limit_is_refused_before_parsing():
    with pytest.raises(SchemaError, match="more than the limit of 100"):
        parse_text("a: [" + "1, " * 100 + "1]", "yaml", limits=Limits(max_bytes=100))


# ------------------------------------------------------------------------------ the reader
DOC = "model:\n  kind: class2\n  parms: {k: 1}\nduration: -1\nseed: 1.5\nrate: 1.0e300\nv: [1, 2]\n"


def _reader_error(fn) -> SchemaError:
    with pytest.raises(SceneError) as info:
        fn(Reader(SceneError, file="s.yaml"), parse_yaml(DOC))
    return info.value


def test_unknown_keys_get_a_suggestion_the_key_path_and_the_line():
    err = _reader_error(lambda r, d: r.keys(d["model"], ("model",), ("kind", "params")))
    assert str(err) == ("s.yaml: model.parms: unknown key 'parms' (did you mean 'params'?); allowed: kind, params "
                        "(line 3)")
    assert err.key == ("model", "parms") and err.line == 3 and err.file == "s.yaml" and err.reason.startswith("unknown")


@pytest.mark.parametrize("check, text, line", [
    (lambda r, d: r.keys(d, (), tuple(d), required=("model", "effects")), "missing required key 'effects'", 1),
    (lambda r, d: r.number(d, "duration", (), unit="s", lo=0.0, lo_open=True), "duration: must be > 0 s, got -1 s", 4),
    (lambda r, d: r.number(d, "duration", (), unit="s", lo=0.0), "duration: must be >= 0 s, got -1 s", 4),
    (lambda r, d: r.number(d, "duration", (), unit="", hi=-2.0), "duration: must be <= -2 (dimensionless), got -1", 4),
    (lambda r, d: r.integer(d, "seed", (), lo=0), "seed: must be a non-negative integer, got 1.5", 5),
    (lambda r, d: r.number(d, "rate", (), unit="Hz"), "rate: must be at most 1e+15 Hz in magnitude, got 1e+300 Hz", 6),
    (lambda r, d: r.vector(d["v"], 3, ("v",), d, "v", unit="m"), "v: must be a list of 3 numbers, got a list ([1, 2])", 7),
    (lambda r, d: r.string(d["model"], "kind", ("model",), choices=("class3", "general")),
     "model.kind: must be one of class3, general, got 'class2' (did you mean 'class3'?)", 2),
    (lambda r, d: r.mapping(d["v"], ("v",), d, "v"), "v: must be a mapping, got a list ([1, 2])", 7),
])
def test_each_check_words_its_failure(check, text, line):
    err = _reader_error(check)
    assert str(err) == f"s.yaml: {text} (line {line})"


def test_numbers_are_bounded_and_infinity_is_allowed_only_when_asked():
    r = Reader()
    assert r.value_number(MAX_MAGNITUDE, ("x",), None, None, unit="m") == 1e15
    assert r.value_number(".inf", ("x",), None, None, unit="m", allow_inf=True) == math.inf
    for bad, words in ((float("nan"), "must be finite"), (10**400, "must be finite"), (True, "must be a number"),
                       ("1", "must be a number, got a string ('1')"), (-1e16, "at most 1e+15 m in magnitude")):
        with pytest.raises(SchemaError, match=words.replace("(", r"\(").replace(")", r"\)").replace("+", r"\+")):
            r.value_number(bad, ("x",), None, None, unit="m")


# ------------------------------------------------------------------------------ key paths
def test_key_paths_round_trip_between_text_and_tuples():
    for text, path in (("effects[2].fold_limit.restitution", ("effects", 2, "fold_limit", "restitution")),
                       ("model.params.k", ("model", "params", "k")), ("[0][1]", (0, 1)), ("", ())):
        assert parse_key_path(text) == path and format_key_path(path) == text
    for bad in ("a..b", "a[x]", "a.", "a[1]b"):
        with pytest.raises(SchemaError, match="cannot read the key path"):
            parse_key_path(bad)


def test_get_at_follows_a_path_and_names_a_missing_key_with_a_suggestion_and_line():
    doc = parse_yaml("model:\n  params: {k: 1.0, c: 0.01}\neffects: [inertia, {fold_limit: {restitution: 0.2}}]\n")
    assert get_at(doc, "effects[1].fold_limit.restitution") == 0.2
    with pytest.raises(SchemaError) as info:
        get_at(doc, "model.parms.k")
    assert str(info.value) == "model: no key 'parms' (did you mean 'params'?); keys: params (line 2)"
    with pytest.raises(SceneError, match=r"no item \[5\] in a list of 2"):
        get_at(doc, ("effects", 5), error=SceneError)


def test_with_value_at_copies_the_path_and_leaves_the_document_alone():
    doc = {"model": {"params": {"k": 1.0}}, "effects": ["inertia", {"damping": {}}]}
    new = with_value_at(doc, "model.params.k", 2.0)
    new2 = with_value_at(new, "effects[1].damping", {"c": 1})
    assert doc["model"]["params"]["k"] == 1.0 and new["model"]["params"]["k"] == 2.0
    assert new2["effects"][1] == {"damping": {"c": 1}} and doc["effects"][1] == {"damping": {}}
    assert new2["model"] is new["model"]                       # untouched branches are shared
    assert with_value_at(doc, "model.params.c", 0.5)["model"]["params"] == {"k": 1.0, "c": 0.5}
    with pytest.raises(SchemaError, match="no key 'modle'"):
        with_value_at(doc, "modle.params.k", 2.0)


def test_set_in_place_changes_the_document_itself():
    doc = {"model": {"params": {"k": 1.0}}, "effects": ["inertia", {"damping": {}}]}
    params = doc["model"]["params"]
    set_in_place(doc, ("model", "params", "k"), 2.0)
    set_in_place(doc, "model.params.c", 0.5)                   # a new last key
    set_in_place(doc, "effects[0]", "gravity")
    assert doc["model"]["params"] is params and params == {"k": 2.0, "c": 0.5}
    assert doc["effects"][0] == "gravity"
    with pytest.raises(SchemaError, match=r"no item \[2\] in a list of 2"):
        set_in_place(doc, "effects[2]", "x")                  # lists do not grow
    with pytest.raises(SchemaError, match="no key 'modle'"):
        set_in_place(doc, "modle.params.k", 2.0)


def test_exists_tells_whether_a_key_path_leads_to_a_value():
    doc = {"model": {"params": {"k": 1.0}}, "effects": ["inertia"]}
    assert exists(doc, "model.params.k") and exists(doc, ("effects", 0)) and exists(doc, "")
    assert not exists(doc, "model.params.c") and not exists(doc, "effects[1]") and not exists(doc, "model.params.k.x")


def test_patterns_select_entries_by_name_and_key_paths_refuse_selectors():
    doc = {"members": [{"name": "side1", "l0": 1.0}, {"name": "top", "l0": 2.0}, {"name": "side2", "l0": 3.0}],
           "effects": ["inertia", "damping"]}
    assert resolve(doc, "members[side*].l0") == [("members", 0, "l0"), ("members", 2, "l0")]
    assert resolve(doc, "effects[damping].c") == [("effects", 1, "damping", "c")]
    assert doc["effects"][1] == {"damping": {}}                # the same effect, with its options mapping
    with pytest.raises(SchemaError, match=r"cannot read the key path 'members\[side\*\]\.l0': \[side\*\] is no list"):
        parse_key_path("members[side*].l0")
    with pytest.raises(SchemaError, match=r"list positions count from 0, got \[-1\]"):
        resolve(doc, "members[-1].l0")


# ------------------------------------------------------------------------------ errors and excerpts
def test_one_error_class_carries_key_line_and_file():
    scene = SceneError("must be > 0, got -1", key=("duration",), line=4, file="s.yaml")
    assert str(scene) == "s.yaml: duration: must be > 0, got -1 (line 4)"
    structure = StructureError("member 's1': unknown node 'x'", entry=("members", 0), line=7)
    assert str(structure) == "member 's1': unknown node 'x' (line 7)"       # names the entry in words
    assert structure.key == structure.entry == ("members", 0)
    for err in (scene, structure):
        assert isinstance(err, SchemaError) and isinstance(err, ValueError)
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is type(err) and str(back) == str(err) and back.key == err.key
    located = structure.located(line=99, file="t.yaml")
    assert str(located) == "t.yaml: member 's1': unknown node 'x' (line 7)" and type(located) is StructureError


def test_excerpts_are_short_whatever_the_value():
    huge = "x" * 70_000
    assert excerpt(huge).endswith("(70000 characters)") and len(excerpt(huge)) < 100
    nested = [[list(range(1000))] * 1000] * 1000            # 10^9 numbers, rendered in a few dozen characters
    assert len(excerpt(nested)) < 100
    assert excerpt(np.float64(np.inf)) == "inf" and excerpt(np.float64(2.5)) == "2.5"
    assert json.loads(excerpt([1, 2])) == [1, 2]


def test_suggestions_among_many_choices_and_for_long_words():
    names = [f"node{i}" for i in range(100_000)]
    assert suggest("node1234x", names) == " (did you mean 'node1234'?)"
    assert suggest("y" * 10_000, names) == ""
