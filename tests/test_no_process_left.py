"""The test run leaves no process behind (issue 12): a run whose test starts a process and
leaves it alive fails at the end of the session, and the process is gone afterwards."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_a_run_that_leaves_a_process_alive_fails_and_kills_it(tmp_path):
    marker = tmp_path / "leaked.pid"
    (tmp_path / "test_leak.py").write_text(
        "import subprocess\n"
        "def test_starts_a_process_and_forgets_it():\n"
        "    p = subprocess.Popen(['sleep', '300'], start_new_session=True)\n"
        f"    open({str(marker)!r}, 'w').write(str(p.pid))\n")
    # the leaked process never exits: the run's wait for late exits (10 s) would only be waited out
    env = {**os.environ, "TENSEGRITY_TEST_LATE_EXITS_S": "0.5"}
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "tests.conftest",
                          "-p", "no:cacheprovider", str(tmp_path / "test_leak.py")],
                         cwd=ROOT, capture_output=True, text=True, timeout=120, env=env)
    assert run.returncode == 1, run.stdout[-2000:]
    assert "1 passed" in run.stdout and "still alive at its end" in run.stdout
    pid = int(marker.read_text())
    assert not os.path.exists(f"/proc/{pid}") or \
        Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
