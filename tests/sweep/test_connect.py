"""Connecting to a scheduler that is not one: a server that accepts and stays silent, and one
that answers with bytes that are not Dask's, each end in one SweepError line within the
connect timeout (+ the margin), never a hang or a MemoryError."""

from __future__ import annotations

import socket
import threading
import time

import pytest

from tensegrity_core.sweep.connect import MARGIN_S, client_of
from tensegrity_core.sweep.errors import SweepError


def _server(reply: bytes):
    """A TCP server on loopback that accepts every connection, writes ``reply`` (may be empty)
    and then holds the connection open without reading; its address and a stop function."""
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.2)
    held: list[socket.socket] = []
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:
                continue
            if reply:
                conn.sendall(reply)
            held.append(conn)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()

    def close() -> None:
        stop.set()
        thread.join()
        for conn in held:
            conn.close()
        listener.close()

    return f"tcp://127.0.0.1:{listener.getsockname()[1]}", close


@pytest.mark.parametrize("reply", [b"", b"HTTP/1.0 400 Bad Request\r\n\r\n" + b"\xff" * 64],
                         ids=["silent", "other protocol"])
def test_a_server_that_is_not_a_scheduler_is_refused_in_time(reply):
    import distributed  # noqa: F401 - imported before the clock starts: the wait, not the import, is timed

    address, close = _server(reply)
    try:
        start = time.monotonic()
        with pytest.raises(SweepError, match=r"^cannot reach the Dask scheduler at 'tcp://127\.0\.0\.1:\d+'") as err:
            client_of(address, 1.0)
        assert time.monotonic() - start < 1.0 + MARGIN_S + 1.0
        assert "\n" not in str(err.value)
    finally:
        close()
