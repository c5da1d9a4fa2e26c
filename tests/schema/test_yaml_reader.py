"""The bounded, line-keeping YAML reader: values as PyYAML's SafeLoader reads them (the
oracle), lines of every key and item, and the bounds that stop bombs while parsing."""

from __future__ import annotations

import datetime
import textwrap

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.schema import Limits, LocatedDict, LocatedList, SchemaError, line_of, parse_yaml

DOC = textwrap.dedent("""\
    name: table            # line 1
    nodes:
      a: [0, 0, 0]         # line 3
      b: [1.5, 0, 0]
    members:
      - {nodes: [a, b], EA: 7.6e10}
      - [b, a]             # line 7
    flags: {on: yes, none: ~, text: '1'}
    """)


def test_keys_and_items_know_their_lines():
    doc = parse_yaml(DOC)
    assert isinstance(doc, LocatedDict) and isinstance(doc["members"], LocatedList)
    assert [line_of(doc, k) for k in doc] == [1, 2, 5, 8]
    assert line_of(doc["nodes"], "b") == 4
    assert doc["members"].item_lines == [6, 7]
    assert line_of(doc["members"][0], "EA") == 6
    assert line_of(doc["members"], 5) == 6          # no such item: the list's own (first) line


def test_values_are_what_safe_load_reads_except_exponents_without_a_dot():
    doc = parse_yaml(DOC)
    oracle = yaml.safe_load(DOC)
    oracle["members"][0]["EA"] = 7.6e10             # YAML 1.1 leaves '7.6e10' a string
    assert doc == oracle
    assert doc["members"][0]["EA"] == 7.6e10 and doc["flags"] == {True: True, "none": None, "text": "1"}


@pytest.mark.parametrize("text, value", [
    ("x: 7.6e10", 7.6e10), ("x: 1e-4", 1e-4), ("x: -.5", -0.5), ("x: 0x1F", 31), ("x: 010", 8),
    ("x: .inf", float("inf")), ("x: 2001-12-14", datetime.date(2001, 12, 14)), ("x: '3'", "3"),
    ("x: !!str 3", "3"), ("x: +12", 12), ("x: 1_000", 1000), ("x: 190:20:30", 685230), ("x: 1.", 1.0),
])
def test_scalars(text, value):
    assert parse_yaml(text)["x"] == value


def test_merge_keys_and_aliases_within_the_budget():
    doc = parse_yaml("d: &d {EA: 1, type: bar}\nm: {<<: *d, type: string}\nn: [*d, *d]\n")
    assert doc["m"] == {"EA": 1, "type": "string"} and doc["n"] == [doc["d"], doc["d"]]


plain = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6)
    | st.floats(allow_nan=False, allow_infinity=False, width=64) | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=20)


@settings(max_examples=100)   # the whole strategy still; an example is 3 dumps and 6 reads, ~11 ms
@given(plain)
def test_anything_pyyaml_writes_reads_back_as_safe_load_reads_it(value):
    for style in (False, True, None):
        text = yaml.safe_dump({"v": value}, default_flow_style=style, allow_unicode=True)
        assert parse_yaml(text) == yaml.safe_load(text)


def _error(text: str, **limits) -> SchemaError:
    with pytest.raises(SchemaError) as info:
        parse_yaml(text, limits=Limits(**limits))
    return info.value


def _bomb(levels: int) -> str:
    """``levels`` anchors, each a list of nine aliases of the one before: 9**levels values."""
    names = "abcdefghijk"
    lines = ["a: &a [" + ",".join(["lol"] * 9) + "]"]
    lines += [f"{names[k]}: &{names[k]} [" + ",".join([f"*{names[k - 1]}"] * 9) + "]" for k in range(1, levels)]
    return "\n".join(lines) + "\n"


def test_an_alias_bomb_is_refused_while_parsing_at_its_line():
    text = _bomb(9)                                   # ~320 bytes standing for 9**9 = 387M values
    assert len(text) < 400
    err = _error(text)
    # anchor k holds 1 + 9 (size of k-1) values: 10, 91, 820, 7381; the aliases of b, c, d add
    # 9 * (10 + 91 + 820) = 8289 values, e's first alias 7381 more: over 10,000 on line 5
    assert "aliases expand to more than 10000 values" in str(err) and err.line == 5
    assert parse_yaml(_bomb(4))["d"][0][0][0][0] == "lol"  # 9**4 values: within the budget


def test_alias_count_recursion_and_undefined_aliases_are_refused():
    assert "more than 3 aliases" in str(_error("a: &a 1\nb: [*a, *a, *a, *a]\n", max_aliases=3))
    assert "inside its own anchor" in str(_error("a: &a [1, *a]\n"))
    assert "undefined alias" in str(_error("a: *nothing\n"))


@pytest.mark.parametrize("text", ["[" * 100_000 + "]" * 100_000,
                                  "x:\n" + "".join(" " * i + "- \n" for i in range(5000)),
                                  "".join("  " * i + f"k{i}:\n" for i in range(100)) + "  " * 100 + "1\n"])
def test_deep_nesting_is_refused_without_recursion(text):
    err = _error(text)
    assert "nested deeper than 64 levels" in str(err) or "maximum nesting depth" in str(err)
    assert err.line is not None


def test_depth_limit_is_the_callers():
    assert parse_yaml("[[[1]]]", limits=Limits(max_depth=3)) == [[[1]]]
    assert _error("[[[[1]]]]", max_depth=3).line == 1


@pytest.mark.parametrize("text, words, line", [
    ("a: 1\na: 2\n", "duplicate key 'a' (first at line 1)", 2),
    ("a: 1\n---\nb: 2\n", "more than one YAML document", 2),
    ("a: !!python/object:os.system x\n", "unsupported tag", 1),
    ("a: !!set {x}\n", "unsupported tag", 1),
    ("? [a]\n: 1\n", "a mapping key must be a single value", 1),
    ("a: [1, 2\n", "invalid YAML", 2),
    ("a: \x01\n", "invalid YAML", 1),
    ("a: " + "7" * 5000 + "\n", "has too many digits", 1),
    ("a: !!int x\n", "cannot read 'x' as int", 1),
    ("m: {<<: [1]}\n", "'<<' merges mappings", 1),
])
def test_malformed_yaml_is_named_with_its_line(text, words, line):
    err = _error(text)
    assert words in str(err) and err.line == line and str(err).endswith(f"(line {line})")


def test_errors_quote_a_short_excerpt_of_a_long_value():
    err = _error("a: " + "9" * 100_000 + "\n")
    assert len(str(err)) < 200 and "(100000 characters)" in str(err)


def test_the_error_class_and_file_are_the_callers():
    class MyError(SchemaError):
        pass

    with pytest.raises(MyError) as info:
        parse_yaml("a: [", error=MyError, file="f.yaml")
    assert str(info.value).startswith("f.yaml: invalid YAML")
