"""Structure files in every format (per-member YAML, the array form in YAML and JSON,
.npz): round trips, located errors, bounds, and entry points that never take text for a
file name."""

from __future__ import annotations

import json
import textwrap
import zipfile

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from yaml import safe_dump

from tensegrity_core.general import (
    StructureError,
    dump_structure,
    example_names,
    form_find,
    load_example,
    load_structure,
    save_structure,
    structure_from_file,
    structure_from_text,
    structure_to_arrays,
    tensegrity_spine,
)
from tensegrity_core.schema import Limits

ARRAYS = ("nodes", "members", "EA", "rest_lengths", "member_masses", "pinned", "loads", "node_masses", "gravity")


def _same(a, b):
    for key in ARRAYS:
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)
    assert (a.name, a.node_names, a.member_names, a.member_kinds, a.bodies) == \
        (b.name, b.node_names, b.member_names, b.member_kinds, b.bodies)


@pytest.mark.parametrize("suffix", [".yaml", ".json", ".npz"])
@pytest.mark.parametrize("name", example_names())
def test_every_example_survives_every_format(tmp_path, name, suffix):
    s = load_example(name)
    _same(structure_from_file(save_structure(s, tmp_path / f"s{suffix}")), s)


def test_a_generated_spine_with_numpy_defaults_round_trips(tmp_path):
    s = tensegrity_spine(40, shape="S", perturbation=0.02, seed=3)
    for suffix in (".yaml", ".json", ".npz"):
        _same(structure_from_file(save_structure(s, tmp_path / f"spine{suffix}")), s)
    arrays = structure_to_arrays(s)
    assert isinstance(arrays["members"], dict) and len(arrays["members"]["nodes"]) == s.n_members


ARRAY_FORM = textwrap.dedent("""\
    name: three strings to a hanging node
    defaults: {EA: 1000.0}
    nodes:
      - [0.0, 0.0, 0.0]
      - [1.0, 0.0, 0.0]
      - [0.0, 1.0, 0.0]
      - [0.3, 0.3, -1.0]
    members:
      nodes: [[0, 3], [1, 3], [2, 3]]
      type: string
      rest_length_ratio: [0.9, 0.9, 0.95]
    pinned: [0, 1, 2]
    loads: {3: [0, 0, -10]}
    """)


def test_the_array_form_reads_like_the_per_member_form():
    per_member = ARRAY_FORM.replace("""members:
  nodes: [[0, 3], [1, 3], [2, 3]]
  type: string
  rest_length_ratio: [0.9, 0.9, 0.95]""", """members:
  - {nodes: [0, 3], rest_length_ratio: 0.9}
  - {nodes: [1, 3], rest_length_ratio: 0.9}
  - {nodes: [2, 3], rest_length_ratio: 0.95}""")
    a, b = structure_from_text(ARRAY_FORM), structure_from_text(per_member)
    _same(a, b)
    length = np.linalg.norm([0.3, 0.3, -1.0])
    np.testing.assert_allclose(a.rest_lengths[[0, 2]], [0.9 * length, 0.95 * np.linalg.norm([0.3, -0.7, -1.0])])
    assert form_find(a).success


@pytest.mark.parametrize("old, new, words, line", [
    ("[[0, 3], [1, 3], [2, 3]]", "[[0, 3], [1, 4], [2, 3]]", "members.nodes[1] must be a pair [a, b] of node positions "
     "0 to 3, got [1, 4]", 9),
    ("[[0, 3], [1, 3], [2, 3]]", "[[0, 3], [1, true], [2, 3]]", "members.nodes[1] must be a pair", 9),
    ("[0.9, 0.9, 0.95]", "[0.9, -0.9, 0.95]", "members.rest_length_ratio[1] must be > 0 (dimensionless), got -0.9", 11),
    ("[0.9, 0.9, 0.95]", "[0.9, 0.95]", "members.rest_length_ratio must have one value per member (3), got 2", 11),
    ("type: string", "type: [string, rope, bar]", "members.type[1]: unknown type 'rope'", 10),
    ("type: string", "type: string\n  colour: red", "members: unknown key 'colour'", 11),
    ("nodes:\n  - [0.0, 0.0, 0.0]", "node_names: [a, b]\nnodes:\n  - [0.0, 0.0, 0.0]",
     "node_names must be a list of 4 names", 3),
    ("  - [0.0, 1.0, 0.0]", "  - [0.0, 1.0, x]", "coordinates of node 2 must be a number, got a string ('x')", 6),
])
def test_array_form_errors_name_the_column_the_index_and_the_line(old, new, words, line):
    with pytest.raises(StructureError) as info:
        structure_from_text(ARRAY_FORM.replace(old, new))
    assert words in str(info.value) and info.value.line == line, str(info.value)


def test_json_errors_are_located_by_reading_the_text_as_yaml(tmp_path):
    data = structure_to_arrays(load_example("t_bar"))
    data["members"]["EA"] = [1.0] * 7 + ["stiff"]
    path = tmp_path / "t.json"
    path.write_text(json.dumps(data, indent=1))
    with pytest.raises(StructureError) as info:
        structure_from_file(path)
    err = info.value
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if '"stiff"' in text)
    assert str(err).startswith("t.json: members.EA[7] must be a number") and err.line == line


def test_text_is_never_taken_for_a_file_name(tmp_path):
    secret = tmp_path / "secret.yaml"
    secret.write_text(dump_structure(load_example("t_bar")).replace("name: ", "name: SECRET-"))
    for text in (str(secret), "/etc/passwd", "/proc/self/environ", str(tmp_path / "missing.yaml")):
        with pytest.raises(StructureError) as info:
            structure_from_text(text)
        assert str(info.value).startswith("a structure description must be a mapping, got a string (")
        assert "SECRET" not in str(info.value) and "root:" not in str(info.value)
    assert load_structure(str(secret)).name.startswith("SECRET-")       # the local convenience reads files


def test_member_counts_are_bounded_before_the_structure_is_built():
    text = dump_structure(tensegrity_spine(30))
    with pytest.raises(StructureError, match="the structure has 232 members, more than the limit of 100"):
        structure_from_text(text, max_members=100)
    assert structure_from_text(text, max_members=232).n_members == 232


def test_text_size_and_nesting_are_bounded():
    with pytest.raises(StructureError, match="more than the limit of 100$"):
        structure_from_text(dump_structure(load_example("t_bar")), limits=Limits(max_bytes=100))
    with pytest.raises(StructureError, match="nested deeper than 64 levels"):
        structure_from_text("nodes: " + "[" * 200 + "]" * 200)


@pytest.mark.parametrize("case, words", [
    ("pickle", "holds object"),
    ("huge", "larger than its file entry"),
    ("missing", "no array member_kinds"),
    ("unknown", "unknown array 'extra'"),
    ("kinds", "member_kinds[0] is 7"),
    ("shape", "array EA must have shape (8,)"),
])
def test_hostile_npz_files_are_refused_before_their_data_is_read(tmp_path, case, words):
    path = tmp_path / "s.npz"
    save_structure(load_example("t_bar"), path)
    with np.load(path) as npz:
        arrays = dict(npz)
    if case == "pickle":
        arrays["EA"] = np.array([object()] * 8, dtype=object)
    elif case == "missing":
        del arrays["member_kinds"]
    elif case == "unknown":
        arrays["extra"] = np.zeros(3)
    elif case == "kinds":
        arrays["member_kinds"] = np.full(8, 7, dtype=np.uint8)
    elif case == "shape":
        arrays["EA"] = np.ones(9)
    np.savez(path, **arrays, allow_pickle=True) if case == "pickle" else np.savez(path, **arrays)
    if case == "huge":                 # a header that claims 10^12 floats for 64 bytes of data
        with zipfile.ZipFile(path) as zf:
            members = {i.filename: zf.read(i) for i in zf.infolist()}
        members["EA.npy"] = members["EA.npy"].replace(b"(8,)", b"(1000000000000,)")
        with zipfile.ZipFile(path, "w") as zf:
            for name, data in members.items():
                zf.writestr(name, data)
    with pytest.raises(StructureError) as info:
        structure_from_file(path)
    assert str(info.value).startswith("s.npz: ") and words in str(info.value), str(info.value)


def test_dump_is_fast_yaml_that_any_yaml_reader_reads_the_same():
    import yaml

    s = load_example("spherical_dodecahedron").replace(name="yes")          # a name YAML 1.1 reads as true
    text = dump_structure(s)
    assert "name: \"yes\"" in text
    plain = yaml.safe_load(text)                                           # PyYAML's own reader, YAML 1.1
    assert plain["name"] == "yes" and all(isinstance(m["EA"], float) for m in plain["members"])
    _same(load_structure(plain), s)


@st.composite
def _descriptions(draw):
    """A valid per-member description in a random mix of entry shapes, with the arrays it
    means computed here from the format's rules (docs/structures.md)."""
    n = draw(st.integers(3, 6))
    coords = [[float(i), float(i * i % 5), float(i % 2)] for i in range(n)]       # distinct points
    d_EA = draw(st.sampled_from([None, 500.0]))
    d_ratio = draw(st.sampled_from([None, 0.8]))
    defaults = {k: v for k, v in (("EA", d_EA), ("rest_length_ratio", d_ratio)) if v is not None}
    if d_EA is None:
        defaults.update(E=2.0e9, A=1.0e-6)
    members, expect = [], []
    for i in range(draw(st.integers(1, 8))):
        a, b = draw(st.sampled_from([(p, q) for p in range(n) for q in range(n) if p != q]))
        length = float(np.linalg.norm(np.subtract(coords[b], coords[a])))
        shape = draw(st.sampled_from(["pair", "map", "aliases", "EA", "E and A", "l0", "ratio", "named"]))
        kind = draw(st.sampled_from(["string", "Cable", "bar", "strut", "actuator"]))
        entry: object = {"nodes": [f"n{a}", f"n{b}"], "type": kind}
        EA, l0 = (d_EA or 2.0e9 * 1.0e-6), (d_ratio or 1.0) * length
        name = f"m{i}"
        if shape == "pair":
            entry, kind = [f"n{a}", f"n{b}"], "string"
        elif shape == "aliases":
            entry = {"ends": [f"n{a}", f"n{b}"], "kind": kind, "l0": 0.5}
            l0 = 0.5
        elif shape == "EA":
            entry["EA"] = EA = 123.0
        elif shape == "E and A":
            entry.update(E=1.0e9, A=3.0e-6)
            EA = 1.0e9 * 3.0e-6
        elif shape == "l0":
            entry["rest_length"] = l0 = 0.25
        elif shape == "ratio":
            entry["rest_length_ratio"] = 0.5
            l0 = 0.5 * length
        elif shape == "named":
            entry["name"] = name = f"member_{i}"
        members.append(entry)
        canon = {"cable": "string", "strut": "bar"}.get(kind.lower(), kind.lower())
        expect.append((name, (a, b), canon, EA, l0))
    data = {"defaults": defaults, "nodes": {f"n{i}": c for i, c in enumerate(coords)}, "members": members,
            "pinned": [f"n{i}" for i in range(n)]}
    return data, expect


@given(_descriptions())
def test_every_entry_shape_means_what_the_format_says(case):
    data, expect = case
    text = safe_dump(data, default_flow_style=None)
    for s in (structure_from_text(text), structure_from_text(json.dumps(data)), load_structure(data)):
        assert s.member_names == tuple(e[0] for e in expect)
        np.testing.assert_array_equal(s.members, np.array([e[1] for e in expect]))
        assert s.member_kinds == tuple(e[2] for e in expect)
        np.testing.assert_allclose(s.EA, [e[3] for e in expect], rtol=1e-15)
        np.testing.assert_allclose(s.rest_lengths, [e[4] for e in expect], rtol=1e-15)
