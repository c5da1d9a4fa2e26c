"""The benchmark harness's verdicts: a target that is a comparison is checked against the
row's value (or its ratio to the baseline), a missed one is printed as such and summarised."""

from __future__ import annotations

import pytest

from tests.bench.__main__ import _summarise_targets
from tests.bench.harness import Row, target_met


@pytest.mark.parametrize("value, unit, target, ratio, met", [
    (3.0, "ms", "< 5 ms", None, True),
    (8.0, "ms", "< 5 ms", None, False),
    (4.9, "us", "< 0.005 ms", None, True),          # another scale of the row's unit
    (5.1, "us", "< 0.005 ms", None, False),
    (0.0, "msgs", "== 0", None, True),
    (125.0, "msgs", "== 0", None, False),
    (0.9, "s CPU", "< 1 s", None, True),              # a unit with words after it
    (1.05, "", "<= 1.1 from 10,000", None, True),     # words after the number are a comment
    (450.0, "ns", "<= 500 ns (>= 2e6 targets/s)", None, True),
    (1.0, "s", ">= 10x", 8.97, False),                # against the ratio to the baseline
    (1.0, "s", ">= 10x", 10.2, True),
    (1.0, "ms", "ratio >= 0.7", 0.69, False),
    (1.0, "s", ">= 10x", None, None),                 # no baseline measured: not checked
    (1.0, "MiB", "< 2 s", None, None),                # another unit: not checked
    (1.0, "", "close to 1", None, None),              # words: not checked
    (float("nan"), "s", "< 2 s", None, False),        # nothing measured misses its target
])
def test_a_comparison_target_is_checked(value, unit, target, ratio, met):
    assert target_met(Row("g", "r", value, unit, target=target, ratio=ratio)) is met


def test_missed_targets_are_summarised_at_the_end(capsys):
    rows = [Row("sim", "quasi-static speed-up", 1.0, "s", baseline="dynamic", target=">= 10x", ratio=8.97, met=False),
            Row("ros", "recorder dropped joint_states", 125.0, "msgs", target="== 0", met=False),
            Row("sweep", "overhead per point", 3.0, "ms", target="< 5 ms", met=True),
            Row("precision", "default method", 1.0, "s", target="on the front")]
    _summarise_targets(rows)
    assert capsys.readouterr().out.splitlines()[1:] == [
        "targets: 1 met, 2 missed of 3 checked (1 in words, not checked)",
        "  MISSED  sim: quasi-static speed-up: 1 s (8.97x against 'dynamic'); target >= 10x",
        "  MISSED  ros: recorder dropped joint_states: 125 msgs; target == 0",
    ]
