"""Starting ``tensegrity view`` as a user does, and reading where it listens."""

from __future__ import annotations

import re

VIEW_READY = re.compile(r"view ready: (http://[^\s:]+:(\d+))")


def start_view(cli, *args: str, timeout: float = 120.0) -> tuple[object, str, int]:
    """``tensegrity view ARGS --port 0``: the process, its URL and port once it is ready."""
    proc = cli("view", *args, "--port", "0", log_name="view")
    proc.wait_for("view ready: ", timeout=timeout)
    m = VIEW_READY.search(proc.stderr())
    assert m, proc.stderr()
    return proc, m.group(1), int(m.group(2))
