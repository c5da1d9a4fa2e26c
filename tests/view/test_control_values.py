"""Control updates no page sends, over a real websocket in viser's protocol: a value of the
wrong type, not finite, outside a number field's range, or another property than the value.
Each is refused before viser applies it, with one log line; no request reaches the source;
the client stays connected, and its next good update is taken."""

from __future__ import annotations

import logging
import math
import threading

import pytest

from tensegrity_ros.view.controls import ControlPanel
from tensegrity_ros.view.inputs import InputSpec
from tensegrity_ros.view.server import start_server
from tests.view.support import PATIENCE, Page


class Requests:
    """A source that offers every control and keeps the requests the page makes of it."""

    features = frozenset({"run", "step", "inputs", "move", "timeline"})
    inputs = (InputSpec("f1", "N", -5.0, 5.0, 0.0),)
    duration = 2.0

    def __init__(self) -> None:
        self.made: list[tuple] = []
        self.changed = threading.Condition()

    def _made(self, *request) -> None:
        with self.changed:
            self.made.append(request)
            self.changed.notify_all()

    def wait(self, count: int) -> list[tuple]:
        with self.changed:
            assert self.changed.wait_for(lambda: len(self.made) >= count, PATIENCE), self.made
            return list(self.made)

    def play(self): self._made("play")                                       # noqa: E704
    def pause(self): self._made("pause")                                     # noqa: E704
    def step(self, steps): self._made("step", steps)                         # noqa: E704
    def drive(self, values): self._made("drive", values)                     # noqa: E704
    def move(self, x, y, duration): self._made("move", x, y, duration)       # noqa: E704
    def seek(self, t): self._made("seek", t)                                 # noqa: E704
    def set_rate(self, rate): self._made("set_rate", rate)                   # noqa: E704


class Refusals(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.lines: list[str] = []
        self.changed = threading.Condition()

    def emit(self, record: logging.LogRecord) -> None:
        with self.changed:
            self.lines.append(record.getMessage())
            self.changed.notify_all()

    def wait(self, count: int) -> list[str]:
        with self.changed:
            assert self.changed.wait_for(lambda: len(self.lines) >= count, PATIENCE), self.lines
            return list(self.lines)


BAD = [
    ("f1 [N]", {"value": "abc"}, "'abc' is not a number"),
    ("f1 [N]", {"value": math.nan}, "nan is not a finite number"),
    ("f1 [N]", {"value": -math.inf}, "-inf is not a finite number"),
    ("f1 [N]", {"value": True}, "True is not a number"),
    ("f1 [N]", {"value": [1.0]}, "[1.0] is not a number"),
    ("f1 [N]", {"max": 1e9}, "it sets ['max'], not only the value"),
    ("f1 [N]", {"value": 1.0, "min": -1e9}, "it sets ['min', 'value'], not only the value"),
    ("steps", {"value": 0}, "0 is outside [1, 100000]"),
    ("steps", {"value": 1e30}, "1e+30 is outside [1, 100000]"),
    ("steps", {"value": math.nan}, "nan is not a finite number"),
    ("duration [s]", {"value": 0.0}, "0.0 is outside [0.05, 600]"),
    ("rate [x real time]", {"value": -1.0}, "-1.0 is outside [0.01, 100]"),
    ("time [s]", {"value": math.inf}, "inf is not a finite number"),
    ("drive from the sliders", {"value": 1}, "1 is not true or false"),
    ("drive from the sliders", {"value": "yes"}, "'yes' is not true or false"),
    ("Step", {"value": "x"}, "'x' is not true or false"),
]


@pytest.fixture
def page():
    refusals = Refusals()
    logging.getLogger("tensegrity_ros.view").addHandler(refusals)
    server = start_server(port=0)
    source = Requests()
    ControlPanel(server.gui, source, lambda _line: None)
    client = Page(server.get_port())
    try:
        yield client, source, refusals
    finally:
        client.close()
        server.stop()
        logging.getLogger("tensegrity_ros.view").removeHandler(refusals)


def test_values_that_do_not_fit_a_control_are_refused_in_one_line_each_and_change_nothing(page):
    client, source, refusals = page
    for k, (label, updates, reason) in enumerate(BAD):
        client.update(label, updates)
        line = refusals.wait(k + 1)[k]
        assert line == f"tensegrity view: refused a value for {label!r} from client 0: {reason}", line
    client.update("steps", {"value": 3})           # the same connection: a good value is taken,
    client.update("Step", {"value": True})         # and the click asks for that many steps
    assert source.wait(1) == [("step", 3)]
    client.update("f1 [N]", {"value": 7.0})        # a slider's value beyond its limit: clamped, not refused
    client.update("drive from the sliders", {"value": True})
    assert source.wait(2)[1] == ("drive", {"f1": 5.0})
    assert len(refusals.lines) == len(BAD)
