"""``tensegrity bag info|plot|repair`` and the CLI's error lines.

The commands run through the command line's ``main`` in this process
(:func:`run_cli_here`: no interpreter start per command); a real process of each bag
command is tests/bags/test_hostile_bags.py's, of ``play`` and ``record`` the tests of
playing and recording."""

from __future__ import annotations

import json

import pytest

from tensegrity_ros.bag.plot import decoded_messages
from tensegrity_ros.bag.reader import BagReader
from tests.bags.conftest import run_cli_here


def test_info_text_and_json(small_bag):
    folder, samples = small_bag
    text = run_cli_here("bag", "info", str(folder))
    assert text.returncode == 0, text.stderr
    assert "Messages:          80" in text.stdout
    assert "Topic: /joint_states | Type: sensor_msgs/msg/JointState" in text.stdout
    assert "Count: 40" in text.stdout and "Serialization Format: cdr" in text.stdout
    info = json.loads(run_cli_here("bag", "info", str(folder), "--json").stdout)
    start = min(t for _, _, t, _, _ in samples)
    end = max(t for _, _, t, _, _ in samples)
    assert (info["start_ns"], info["end_ns"]) == (start, end)
    assert info["duration_s"] == (end - start) / 1e9
    assert {t["name"]: (t["type"], t["count"]) for t in info["topics"]} == {
        "/joint_states": ("sensor_msgs/msg/JointState", 40),
        "/end_effector": ("geometry_msgs/msg/PointStamped", 40)}
    assert info["size_bytes"] == (folder / "small_0.mcap").stat().st_size
    assert info["notes"] == [] and info["recovered"] is False


def test_plot_decodes_without_ros_and_writes_png(small_bag, tmp_path):
    folder, samples = small_bag
    decoded = list(decoded_messages(BagReader(folder), ["/joint_states", "/end_effector"]))
    assert [list(m.position) for t, _, m in decoded if t == "/joint_states"] == \
        [v for topic, *_, v in samples if topic == "/joint_states"]
    assert [(m.point.x, m.point.y, m.point.z) for t, _, m in decoded if t == "/end_effector"] == \
        [v for topic, *_, v in samples if topic == "/end_effector"]
    out = tmp_path / "plot.png"
    done = run_cli_here("bag", "plot", str(folder), "-o", str(out))
    assert done.returncode == 0, done.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10_000


def test_repair_cli_and_info_on_a_killed_bag(small_bag):
    folder, _ = small_bag
    data = (folder / "small_0.mcap").read_bytes()
    (folder / "small_0.mcap").write_bytes(data[: len(data) // 2])
    (folder / "metadata.yaml").unlink()
    info = json.loads(run_cli_here("bag", "info", str(folder), "--json").stdout)
    assert info["recovered"] is True and len(info["notes"]) == 2
    done = run_cli_here("bag", "repair", str(folder), "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["rewritten"] and result["message_count"] == info["message_count"]
    assert json.loads(run_cli_here("bag", "info", str(folder), "--json").stdout)["notes"] == []


def test_errors_are_one_line(tmp_path):
    """Exit code 1 for a bag problem, 2 for a refused option value (docs/bags.md)."""
    for args, needle, code in (
        (("bag", "info", str(tmp_path / "missing")), "does not exist", 1),
        (("play", str(tmp_path / "missing")), "does not exist", 1),
        (("play", str(tmp_path), "--rate", "0"), "rate must be a finite number > 0", 2),
        (("play", str(tmp_path), "--start-offset", "-1"), "start offset must be >= 0 s", 2),
        (("play", str(tmp_path), "--clock", "-5"), "clock rate must be in (0, 10000] Hz", 2),
        (("record", "-o", str(tmp_path)), "exists already", 1),
        (("bag", "plot", str(tmp_path / "missing"), "-o", str(tmp_path / "x.png")), "does not exist", 1),
    ):
        done = run_cli_here(*args)
        assert done.returncode == code, (args, done.returncode, done.stderr)
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], done.stderr


@pytest.mark.parametrize("command", [("bag", "plot", "{bag}", "-o", "{png}"), ("play", "{bag}", "--resimulate")],
                         ids=["plot", "resimulate"])
def test_a_bag_with_a_damaged_message_is_one_line_naming_it(tmp_path, command):
    """A joint state cut short inside its positions: exit 1 and the bag, topic and message in
    one line, not the CDR reader's struct.error or rclpy's RMWError; no plot is written."""
    from pathlib import Path

    from tests.bags.damaged import damaged_copy

    bag, png = tmp_path / "damaged", tmp_path / "x.png"
    damaged_copy(Path(__file__).resolve().parents[2] / "bags" / "fold", bag, "/joint_states", 3, 30)
    done = run_cli_here(*(word.format(bag=bag, png=png) for word in command))
    assert done.returncode == 1, done.stderr
    logged = [m.log_time_ns for m in BagReader(bag).messages(["/joint_states"])][3]
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        f"error: bag {bag}: the message of /joint_states logged at {logged} ns cannot be decoded (30 bytes: "), lines
    assert not png.exists()


def test_a_robots_plot_keeps_its_legend_off_the_plots():
    """The 6-bar's bag has 24 joints: their legend goes beside the joints' plot, inside the
    figure, covering neither plot (inside, it ran down over both)."""
    from pathlib import Path

    import matplotlib.pyplot as plt

    from tensegrity_ros.bag.plot import bag_figure
    from tests.plot_checks import assert_readable

    fig = bag_figure(Path(__file__).resolve().parents[2] / "bags" / "six_bar_roll")
    try:
        assert_readable(fig)
        renderer = fig.canvas.get_renderer()
        legend = fig.axes[0].get_legend()
        assert len(legend.get_texts()) == 24
        box = legend.get_window_extent(renderer)
        assert fig.bbox.contains(box.x0, box.y0) and fig.bbox.contains(box.x1, box.y1)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), ax.get_title()
    finally:
        plt.close(fig)
