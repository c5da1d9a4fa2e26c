"""The benchmark harness's verdicts: a target that is a comparison is checked against the
row's value (or its ratio to the baseline), a missed one is printed as such and summarised."""

from __future__ import annotations

import pytest

from tests.bench.__main__ import _summarise_targets
from tests.bench.harness import Row, format_ratio, is_rate, ratio_to_baseline, target_met


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
    (15.0, "us/call", "< 20 us", 3.0, True),          # per call: the target is per call
    (0.025, "ms/call", "< 20 us", None, False),
    (600.0, "steps/s", ">= 500", None, True),
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


@pytest.mark.parametrize("unit, rate", [
    ("Hz", True), ("kHz", True), ("fps", True), ("states/s", True), ("1/s", True), ("steps/s", True),
    ("s", False), ("ms", False), ("s/s", False), ("us/call", False), ("s CPU", False), ("MiB", False), ("", False),
])
def test_a_rate_is_told_by_its_unit(unit, rate):
    assert is_rate(unit) is rate


def test_the_ratio_reads_right_for_a_rate_and_for_a_time():
    """A rate is compared as value / baseline (13.5 of 60.75 fps is 2/9 of it), a time as
    baseline / value (1 s against 4.5 s is 4.5 times faster)."""
    page = Row("view", "page", 13.5, "fps", baseline="empty")
    page.ratio = ratio_to_baseline(page, Row("view", "empty", 60.75, "fps"))
    assert page.ratio == pytest.approx(2 / 9) and format_ratio(page) == "0.22x of baseline"
    fast = Row("sim", "fast", 1.0, "s", baseline="slow")
    fast.ratio = ratio_to_baseline(fast, Row("sim", "slow", 4.5, "s"))
    assert fast.ratio == pytest.approx(4.5) and format_ratio(fast) == "4.50x"
    assert ratio_to_baseline(page, Row("view", "empty", 0.0, "fps")) is None
    assert ratio_to_baseline(Row("sim", "zero", 0.0, "s"), Row("sim", "slow", 4.5, "s")) is None


def test_a_missed_rate_is_summarised_as_a_part_of_its_baseline(capsys):
    rows = [Row("view", "frames rendered per s", 13.5, "fps", baseline="empty page", target="ratio >= 0.5",
                ratio=2 / 9, met=False)]
    _summarise_targets(rows)
    assert capsys.readouterr().out.splitlines()[2] == \
        "  MISSED  view: frames rendered per s: 13.5 fps (0.222x of 'empty page'); target ratio >= 0.5"


def test_full_mode_under_chosen_kernels_leaves_the_docs_files_alone(tmp_path, monkeypatch, capsys):
    """``--full`` writes the docs' table and figures, which are the default kernels': with
    TENSEGRITY_KERNELS set it refuses (one line, exit 2) unless every output goes elsewhere.
    The runner's ``main`` in this process (its refusals are argparse's exit): the process
    start of ``python -m tests.bench`` is tested by tests/bench/test_quick_mode.py."""
    from tests.bench.__main__ import main

    monkeypatch.setenv("TENSEGRITY_KERNELS", "numpy")
    with pytest.raises(SystemExit) as refused:
        main(["--full", "--only", "no_such_group"])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and "TENSEGRITY_KERNELS=numpy with --full" in err, err
    elsewhere = ["--json", str(tmp_path / "r.json"), "--plot-dir", str(tmp_path), "--data-dir", str(tmp_path)]
    with pytest.raises(SystemExit) as refused:
        main(["--full", "--only", "no_such_group", *elsewhere])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and "unknown group(s) no_such_group" in err, err
