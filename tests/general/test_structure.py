"""Structure descriptions: loading (YAML, TOML, dict, path), validation errors, round trips."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from tensegrity_core.errors import TensegrityError
from tensegrity_core.general import (
    RigidBody,
    Structure,
    StructureError,
    dump_structure,
    example_names,
    load_example,
    load_structure,
    structure_to_dict,
)

GOOD = textwrap.dedent("""\
    name: two bodies
    defaults: {E: 7.6e10, A: 1.0e-4}
    nodes:
      a: [0, 0, 0]
      b: [1, 0, 0]
      c: [0, 1, 0]
      d: [0, 0, 2]
      e: [1, 0, 2]
      f: [0, 1, 2]
      g: [0.5, 0.5, 3]
    members:
      - {name: s1, nodes: [a, d], type: cable, rest_length_ratio: 0.9}
      - {name: s2, nodes: [b, e], type: string, l0: 1.5}
      - [c, f]
      - {nodes: [f, g], type: strut, EA: 1.0e7}
    pinned: {g: xyz}
    bodies:
      - {name: low, nodes: [a, b, c], mass: 2.0}
      - {name: high, nodes: [d, e, f]}
    loads: {e: [0, 0, -10]}
    masses: {d: 0.5}
    gravity: [0, 0, -9.81]
    """)


def test_yaml_text_is_loaded_in_description_order_with_aliases():
    s = load_structure(GOOD)
    assert s.node_names == ("a", "b", "c", "d", "e", "f", "g")
    assert s.member_names == ("s1", "s2", "m2", "m3")
    assert s.member_kinds == ("string", "string", "string", "bar")
    np.testing.assert_allclose(s.EA, [7.6e6, 7.6e6, 7.6e6, 1.0e7])
    np.testing.assert_allclose(s.rest_lengths, [0.9 * 2.0, 1.5, 2.0, math.sqrt(0.5 + 1.0)])
    assert s.pinned[6].all() and not s.pinned[:6].any()
    assert [b.name for b in s.bodies] == ["low", "high"] and s.bodies[0].mass == 2.0
    np.testing.assert_allclose(s.loads[4], [0, 0, -10])
    np.testing.assert_allclose(s.external_forces[3], [0, 0, -0.5 * 9.81])
    assert s.layout.n_dof == 12


def test_yaml_floats_without_dot_or_exponent_sign_are_numbers():
    """PyYAML (YAML 1.1) reads 7.6e10 and 1e-4 as strings; the loader reads numbers."""
    s = load_structure("nodes: {a: [0,0,0], b: [1e0, 0, 0]}\nmembers: [{nodes: [a, b], EA: 7e6}]\n"
                       "pinned: [a]\n")
    assert s.EA[0] == 7e6 and s.nodes[1, 0] == 1.0


def test_toml_text_file_and_dict_give_the_same_structure(tmp_path):
    toml = textwrap.dedent("""\
        name = "bar"
        [nodes]
        a = [0.0, 0.0, 0.0]
        b = [2.0, 0.0, 0.0]
        [[members]]
        nodes = ["a", "b"]
        type = "bar"
        EA = 1000.0
        rest_length = 1.5
        [pinned]
        a = "xyz"
        b = "yz"
        """)
    from_text = load_structure(toml)
    path = tmp_path / "bar.toml"
    path.write_text(toml)
    from_file = load_structure(path)
    from_str_path = load_structure(str(path))
    import tomllib

    from_dict = load_structure(tomllib.loads(toml))
    for s in (from_file, from_str_path, from_dict):
        np.testing.assert_array_equal(s.nodes, from_text.nodes)
        np.testing.assert_array_equal(s.rest_lengths, from_text.rest_lengths)
        np.testing.assert_array_equal(s.pinned, from_text.pinned)
    assert from_text.rest_lengths[0] == 1.5


@pytest.mark.parametrize("name", example_names())
def test_dump_and_load_round_trip_every_example(name):
    s = load_example(name)
    back = load_structure(dump_structure(s, "header\nline"))
    for key in ("nodes", "members", "EA", "rest_lengths", "pinned", "loads", "node_masses", "gravity"):
        np.testing.assert_array_equal(getattr(back, key), getattr(s, key), err_msg=key)
    assert back.member_kinds == s.member_kinds and back.bodies == s.bodies
    assert structure_to_dict(back) == structure_to_dict(s)


def test_structure_is_immutable():
    s = load_structure(GOOD)
    with pytest.raises(ValueError):
        s.nodes[0, 0] = 5.0
    with pytest.raises(AttributeError):
        s.name = "other"
    s2 = s.with_rest_lengths(s.rest_lengths * 0.5)
    assert s2.rest_lengths[0] == 0.5 * s.rest_lengths[0] and s.rest_lengths[0] == 0.9 * 2.0


def _err(text: str) -> StructureError:
    with pytest.raises(StructureError) as info:
        load_structure(textwrap.dedent(text))
    assert isinstance(info.value, TensegrityError) and isinstance(info.value, ValueError)
    return info.value


BASE = """\
    nodes:
      a: [0, 0, 0]
      b: [1, 0, 0]
      c: [0, 1, 0]
      d: [0, 0, 1]
    members:
      - {name: s1, nodes: [a, b], EA: 100}
      - {name: s2, nodes: [b, c], EA: 100}
      - {name: s3, nodes: [c, d], EA: 100}
    pinned: [a]
    """


def test_the_base_description_is_valid():
    assert load_structure(textwrap.dedent(BASE)).n_members == 3


@pytest.mark.parametrize("old, new, words, line", [
    ("nodes: [a, b], EA: 100}", "nodes: [a, x], EA: 100}", ["unknown node 'x'", "s1"], 7),
    ("nodes: [b, c], EA: 100}", "nodes: [b, b], EA: 100}", ["s2", "joins node 'b' to itself"], 8),
    ("d: [0, 0, 1]", "d: [0, 1, 0]", ["s3", "zero length", "'c'", "'d'"], 9),
    ("EA: 100}\n  - {name: s3", "EA: .nan}\n  - {name: s3", ["s2", "EA", "finite"], 8),
    ("EA: 100}\n  - {name: s3", "EA: -5}\n  - {name: s3", ["s2", "EA must be > 0 N, got -5 N"], 8),
    ("EA: 100}\n  - {name: s3", "EA: 0}\n  - {name: s3", ["s2", "EA must be > 0 N, got 0 N"], 8),
    ("EA: 100}\n  - {name: s3", "EA: '100'}\n  - {name: s3", ["s2", "EA", "number", "'100'"], 8),
    ("{name: s1, nodes: [a, b], EA: 100}", "{name: s1, nodes: [a, b], EA: 100, colour: red}",
     ["members[0]", "unknown key 'colour'"], 7),
    ("{name: s1, nodes: [a, b], EA: 100}", "{name: s1, nodes: [a, b], EA: 100, type: rope}",
     ["s1", "unknown type 'rope'"], 7),
    ("{name: s1, nodes: [a, b], EA: 100}", "{name: s1, nodes: [a, b]}", ["s1", "axial stiffness missing"], 7),
    ("{name: s1, nodes: [a, b], EA: 100}", "{name: s1, nodes: [a, b], EA: 100, l0: 1, rest_length_ratio: 1}",
     ["s1", "not both"], 7),
    ("{name: s1, nodes: [a, b], EA: 100}", "{name: s1, nodes: [a, b], E: 1.0e9, EA: 100}", ["s1", "not both"], 7),
    ("b: [1, 0, 0]", "b: [1, 0]", ["coordinates of node 'b'", "3 numbers"], 3),
    ("b: [1, 0, 0]", "b: [1, zero, 0]", ["coordinates of node 'b'", "number", "'zero'"], 3),
    ("pinned: [a]", "pinned: {a: xw}", ["pinned", "unknown axis 'w'"], 10),
    ("pinned: [a]", "pinned: [a]\nloads: {q: [0, 0, 1]}", ["loads", "unknown node 'q'"], 11),
    ("pinned: [a]", "pinned: [a]\nmasses: {b: -1}", ["point mass of node 'b'", ">= 0"], 11),
    ("pinned: [a]", "pinned: [a]\ngravity: [0, 0]", ["gravity", "3 numbers"], 11),
    ("pinned: [a]", "pinned: [a]\ncolour: red", ["unknown key 'colour'"], 11),
    ("pinned: [a]", "pinned: [a]\nunits: imperial", ["units", "SI"], 11),
    ("pinned: [a]", "pinned: [a]\nmember: []", ["unknown key 'member'", "did you mean 'members'"], 11),
    ("c: [0, 1, 0]", "c: [0, 1, 0]\n  c: [0, 2, 0]", ["duplicate key 'c' (first at line 4)"], 5),
])
def test_bad_input_names_the_entry_and_its_line(old, new, words, line):
    text = textwrap.dedent(BASE)
    assert old in text
    err = _err(text.replace(old, new, 1))
    for w in words:
        assert w in str(err), (w, str(err))
    assert err.line == line and f"line {line}" in str(err)


BODY = """\
    nodes:
      a: [0, 0, 0]
      b: [1, 0, 0]
      c: [0, 1, 0]
      d: [0, 0, 2]
      e: [1, 0, 2]
      f: [0, 1, 2]
    members:
      - {nodes: [a, d], EA: 100}
      - {nodes: [b, e], EA: 100}
      - {nodes: [c, f], EA: 100}
    rigid_bodies:
      - {name: low, nodes: [a, b, c]}
      - {name: high, nodes: [d, e, f]}
    """


def test_the_body_description_is_valid():
    assert len(load_structure(textwrap.dedent(BODY)).bodies) == 2


@pytest.mark.parametrize("old, new, words, line", [
    ("{name: high, nodes: [d, e, f]}", "{name: high, nodes: [c, e, f]}",
     ["node 'c' is in two rigid bodies", "'low'", "'high'"], 14),
    ("{name: high, nodes: [d, e, f]}", "{name: high, nodes: [d, e]}",
     ["'high' has 2 node(s)", "at least 3 non-collinear"], 14),
    ("f: [0, 1, 2]", "f: [2, 0, 2]", ["'high'", "collinear"], 14),
    ("{name: high, nodes: [d, e, f]}", "{name: high, nodes: [d, e, z]}", ["rigid body 'high'", "unknown node 'z'"], 14),
    ("{name: high, nodes: [d, e, f]}", "{name: high, nodes: [d, e, f], mass: -1}", ["'high'", "mass", ">= 0"], 14),
    ("{name: high, nodes: [d, e, f]}", "{name: high, nodes: [d, e, f], fixed: 1}", ["'high'", "true or false"], 14),
    ("{name: high, nodes: [d, e, f]}", "{name: high, nodes: [d, e, f], shape: box}", ["unknown key 'shape'"], 14),
    ("rigid_bodies:", "pinned: {d: z}\nrigid_bodies:", ["node 'd'", "'high'", "fixed: true"], 15),
    ("- {nodes: [c, f], EA: 100}", "- {nodes: [c, f], EA: 100}\n  - {name: inner, nodes: [d, e], EA: 100}",
     ["'inner'", "same rigid body 'high'"], 12),
])
def test_bad_rigid_bodies_are_named(old, new, words, line):
    text = textwrap.dedent(BODY)
    assert old in text
    err = _err(text.replace(old, new, 1))
    for w in words:
        assert w in str(err), (w, str(err))
    assert err.line == line


def test_other_errors():
    assert "no 'members'" in str(_err("nodes: {a: [0, 0, 0]}\n"))
    assert "must be a mapping" in str(_err("- 1\n- 2\n"))
    bad_yaml = _err("nodes: {a: [0, 0, 0]}\nmembers: [\n")
    assert str(bad_yaml).startswith("invalid YAML: ") and bad_yaml.line == 3 and str(bad_yaml).endswith("(line 3)")
    loose = _err("nodes: {a: [0,0,0], b: [1,0,0], c: [5,5,5]}\nmembers: [{nodes: [a, b], EA: 1}]\npinned: [a]\n")
    assert "node 'c' is free but no member is attached" in str(loose)
    with pytest.raises(StructureError, match="structure file not found: 'missing.yaml'"):
        load_structure("missing.yaml")
    with pytest.raises(StructureError, match="invalid TOML"):
        load_structure("a = [\n")


def test_python_construction_validates_too():
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    with pytest.raises(StructureError, match="refers to node index"):
        Structure.from_arrays(nodes, [[0, 3]], EA=1.0)
    with pytest.raises(StructureError, match="EA must be finite and positive"):
        Structure.from_arrays(nodes, [[0, 1], [1, 2]], EA=[1.0, np.inf])
    with pytest.raises(StructureError, match="needs at least 3 non-collinear"):
        Structure.from_arrays(nodes, [[0, 2]], EA=1.0, bodies=[RigidBody("r", (0, 1))])
    s = Structure.from_arrays(nodes, [[0, 1], [1, 2]], EA=1.0, pinned=[True, False, True])
    assert s.layout.n_dof == 3 and s.member_names == ("m0", "m1")


def test_the_examples_in_docs_structures_md_load_and_form_find():
    import re
    from pathlib import Path

    from tensegrity_core.general import form_find

    text = (Path(__file__).parents[2] / "docs" / "structures.md").read_text()
    blocks = re.findall(r"```(yaml|toml)\n(.*?)```", text, re.S)
    descriptions = [b for _, b in blocks if not b.startswith("structure:") and ("nodes:" in b or "[nodes]" in b)]
    assert len(descriptions) == 3                  # per member (YAML), TOML, the array form
    for text in descriptions:
        r = form_find(load_structure(text))
        assert r.success, r.message
