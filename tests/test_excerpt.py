"""tensegrity_core.excerpt: outside values in messages are bounded, whatever their size."""

from __future__ import annotations

import pytest
import yaml

from tensegrity_core.excerpt import DEFAULT_LIMIT, clip, excerpt


@pytest.mark.parametrize("value", ["f3", b"ab", 1.5, None, ["a", 1], {"k": "v"}])
def test_short_values_are_their_repr(value):
    assert excerpt(value) == repr(value)


@pytest.mark.parametrize("value, unit", [("x" * 65536, "65536 characters"),
                                         ("\x00" * 1000, "1000 characters"),
                                         (b"\xff" * 5000, "5000 bytes")])
def test_long_text_keeps_its_start_and_says_its_length(value, unit):
    out = excerpt(value)
    assert len(out) <= DEFAULT_LIMIT + 25 and out.endswith(f"… ({unit})")
    assert out[1:11] == repr(value)[1:11] or out[2:12] == repr(value)[2:12]


def test_deep_and_alias_expanded_structures_render_small_and_fast():
    deep = []
    node = deep
    for _ in range(100_000):           # deeper than the interpreter could repr
        node.append([])
        node = node[0]
    assert len(excerpt(deep)) <= DEFAULT_LIMIT + 1
    levels = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"] + [
        f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 9) + "]" for k in range(1, 9)]
    bomb = yaml.safe_load("\n".join(levels))   # 9**9 leaves if expanded
    assert len(excerpt(bomb)) <= DEFAULT_LIMIT + 1


def test_numpy_scalars_show_as_plain_numbers_also_inside_containers():
    """A message quoting ``list(array[:3])`` once read ``got [np.float64(-1.0)] s``."""
    import numpy as np

    assert excerpt([np.float64(-1.0), np.float32(2.5)]) == "[-1.0, 2.5]"
    assert excerpt({"t": (np.int64(3), np.float64("inf"))}) == "{'t': (3, inf)}"
    assert excerpt(np.float64(0.5)) == "0.5"


def test_clip_bounds_a_whole_message():
    assert clip("short") == "short"
    out = clip("e" * 10_000, 100)
    assert out.startswith("e" * 100) and out.endswith("(10000 characters)") and len(out) < 130
