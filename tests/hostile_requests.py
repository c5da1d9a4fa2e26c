"""The hostile ``find_form`` requests of issue 12, built as text (shared by the node's tests,
``tests/ros/test_formfind_hostile.py``, and the benchmark that measures them,
``tests/bench/bench_hostile.py``), and the memory of a process as ``/proc`` tells it.
"""

from __future__ import annotations

from tensegrity_core.general import example_path

#: The shipped tensegrity table's description: a good request.
TABLE = example_path("tensegrity_table").read_text()


def alias_bomb() -> str:
    """About 300 bytes of YAML whose aliases stand for 9**8 = 43 million values in the
    structure's name (eight anchors, each a list of nine aliases of the one before)."""
    names = "abcdefgh"
    parts = ["&a [" + ",".join(['"lol"'] * 9) + "]"]
    parts += [f"&{names[k]} [" + ",".join([f"*{names[k - 1]}"] * 9) + "]" for k in range(1, 8)]
    return f"name: [{', '.join(parts)}, *h]\n"


def deep_flow_nesting(depth: int = 100_000) -> str:
    """``nodes:`` followed by ``depth`` nested flow lists (2 * depth + 8 bytes)."""
    return "nodes: " + "[" * depth + "]" * depth + "\n"


def huge_value(chars: int = 65536) -> str:
    """The table with its ``units`` value replaced by ``chars`` characters ('k')."""
    return TABLE.replace("units: SI", "units: " + "k" * chars)


def tower_yaml(members: int) -> str:
    """A generated tower of cubes as a compact per-member description (list nodes, pairs):
    ``members`` members (60,000 make about 1.4 MB)."""
    levels = members // 12 + 2
    lines = ["defaults: {EA: 1000.0, rest_length_ratio: 0.99}", "nodes:"]
    lines += [f"  - [{x}, {y}, {z}]" for z in range(levels) for y in (0, 1) for x in (0, 1)]
    edges = ((0, 1), (1, 3), (3, 2), (2, 0), (0, 4), (1, 5), (2, 6), (3, 7), (0, 5), (1, 7), (3, 6), (2, 4))
    pairs = [(4 * z + a, 4 * z + b) for z in range(levels - 1) for a, b in edges][:members]
    return "\n".join(lines + ["members:"] + [f"  - [{a}, {b}]" for a, b in pairs] + ["pinned: [0, 1, 2, 3]"]) + "\n"


def memory_mib(pid: int) -> dict[str, float]:
    """``VmRSS`` (resident now) and ``VmHWM`` (peak resident) of process ``pid`` [MiB], from
    ``/proc/<pid>/status``; missing keys when the process is a zombie. Raises OSError when
    the process is gone."""
    out = {}
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(value.split()[0]) / 1024
    return out
