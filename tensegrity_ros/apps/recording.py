"""``tensegrity record`` as a child process that reports when it is ready, for programs that
must record a run from its first step (``tensegrity demo``).

The recorder logs ``recording /topic ...`` when it subscribes, ``matched N publisher(s) on
/topic`` when its reader's matched publishers change and ``first message on /topic`` when a
topic's first message arrives (:mod:`tensegrity_ros.bag.recorder`). That the graph shows the
recorder's subscription proves neither side's match, and a volatile message published
before both sides matched is lost for good; a message received proves both. So
:meth:`Recorder.wait_ready` makes the publishers publish (``provoke``: e.g. a
``ResetSimulation`` of a paused simulator republishes its state at once, unchanged) until
the first message of every topic that such a publication carries has arrived, and for the
topics nothing publishes before the run (events, commands) waits for the recorder's reader
to have matched their publishers.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from tensegrity_core.errors import TensegrityError

_FIRST = re.compile(r"first message on (\S+)$")
_MATCHED = re.compile(r"matched (\d+) publisher\(s\) on (\S+)$")


class RecorderNotReady(TensegrityError, RuntimeError):
    """The recorder did not get a first message or match a publisher in time."""


class Recorder:
    """``tensegrity record -o FOLDER TOPICS... [ROS args]`` as a child process, stopped with
    SIGINT (which finishes the bag). Topic names in its reports are absolute (``/joint_states``)."""

    def __init__(self, folder: Path, args: list[str]):
        self.folder = folder
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tensegrity_ros.cli", "record", "-o", str(folder), *args],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self.lines: list[str] = []
        self._first: set[str] = set()
        self._matched: dict[str, int] = {}
        self._changed = threading.Condition()      # reentrant: missing() is called inside too
        self._pump_thread = threading.Thread(target=self._pump, daemon=True)
        self._pump_thread.start()

    def _pump(self) -> None:
        assert self.proc.stderr is not None
        for raw in self.proc.stderr:
            line = raw.rstrip()
            with self._changed:
                self.lines.append(line)
                if m := _FIRST.search(line):
                    self._first.add(m.group(1))
                elif m := _MATCHED.search(line):
                    self._matched[m.group(2)] = int(m.group(1))
                self._changed.notify_all()
        with self._changed:
            self._changed.notify_all()

    def missing(self, first: Iterable[str], matched: Mapping[str, int]) -> list[str]:
        """What the recorder has not reported yet: topics of ``first`` without a first
        message, topics of ``matched`` with fewer matched publishers than asked."""
        with self._changed:
            return ([f"a first message on {t}" for t in first if t not in self._first]
                    + [f"{n} publisher(s) matched on {t}" for t, n in matched.items()
                       if self._matched.get(t, 0) < n and t not in self._first])

    def wait_ready(self, first: Iterable[str], provoke: Callable[[], object], *,
                   matched: Mapping[str, int] | None = None, every: float = 1.0, timeout: float = 60.0) -> int:
        """Call ``provoke()`` (make the publishers publish once) every ``every`` s until the
        recorder reports a first message on every topic of ``first`` and, on each topic of
        ``matched``, at least that many matched publishers (or a first message); return how
        many times it provoked. :class:`RecorderNotReady` after ``timeout`` s or when the
        recorder exits."""
        first, matched = list(first), dict(matched or {})
        deadline = time.monotonic() + timeout
        provoked = 0
        while self.missing(first, matched):
            if time.monotonic() > deadline:
                raise RecorderNotReady(f"the recorder of {self.folder} reported no "
                                       f"{', no '.join(self.missing(first, matched))} within {timeout:g} s")
            provoke()
            provoked += 1
            until = min(deadline, time.monotonic() + every)
            with self._changed:
                while self.missing(first, matched) and time.monotonic() < until:
                    if self.proc.poll() is not None:
                        raise RecorderNotReady("the recorder exited: " + " / ".join(self.lines[-5:]))
                    self._changed.wait(max(0.0, min(0.1, until - time.monotonic())))
        return provoked

    def wait_complete(self, expected: Mapping[str, Iterable[int]], timeout: float = 15.0) -> dict[str, list[int]]:
        """Wait until the bag being written holds every stamp [ns] of ``expected`` (absolute
        topic -> stamps; read from the file as a recovering reader does, the recorder writes
        its chunks within 0.1 s) or ``timeout`` s passed; return what is still missing. A
        recorder that stalled (a loaded machine) gets what it missed from the writers'
        history at their next heartbeat, up to a few seconds later: stopping it before that
        would lose them."""
        from tensegrity_ros.bag.completeness import missing_stamps
        from tensegrity_ros.bag.errors import BagError

        expected = {t: list(s) for t, s in expected.items()}
        deadline = time.monotonic() + timeout
        while True:
            try:
                missing = missing_stamps(self.folder, expected)
            except BagError:                      # nothing written yet
                missing = {t: sorted(s) for t, s in expected.items()}
            if not any(missing.values()) or time.monotonic() > deadline or self.proc.poll() is not None:
                return missing
            time.sleep(0.2)

    def stop(self) -> int:
        """SIGINT, then wait for the bag to be closed; the recorder's exit code."""
        self.proc.send_signal(signal.SIGINT)
        code = self.proc.wait(60)
        self._pump_thread.join(5.0)
        return code
