"""The embedded cluster's worker set-up: a closing worker's cut heartbeat stays off the
terminal, and nothing else does (the race itself, about once in 30 Ctrl-C'd sweeps, is too
rare to provoke in a test; the filter is checked on Dask's own record and statuses)."""

from __future__ import annotations

import inspect
import logging
from types import SimpleNamespace

import pytest

from tensegrity_core.sweep.worker_setup import HEARTBEAT_FAILED, _HeartbeatCutByClosing


def record(message: str) -> logging.LogRecord:
    return logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, message, None, None)


def test_the_message_filtered_is_the_one_dask_logs_when_a_heartbeat_fails():
    from distributed.worker import Worker

    assert f'"{HEARTBEAT_FAILED}.")' in inspect.getsource(Worker.heartbeat)


@pytest.mark.parametrize("status, shown", [("running", True), ("paused", True), ("init", True),
                                           ("closing", False), ("closing_gracefully", False),
                                           ("closed", False)])
def test_a_failed_heartbeat_is_dropped_only_while_the_worker_closes(status, shown):
    """``status``: the name of one of Dask's worker statuses (``distributed.core.Status``)."""
    from distributed.core import Status

    worker = SimpleNamespace(status=Status[status])
    keep = _HeartbeatCutByClosing(worker)
    assert keep.filter(record(f"{HEARTBEAT_FAILED}.")) is shown
    assert keep.filter(record("Unexpected exception during heartbeat. Closing worker.")) is True
    assert keep.filter(record("Worker stream died during communication")) is True
