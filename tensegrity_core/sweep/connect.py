"""Connecting to an existing Dask scheduler with the whole hand-shake bounded.

distributed's ``Client(address, timeout=...)`` bounds reaching the address, not what answers
there: a server that accepts the connection and then says nothing (an HTTP server waiting for a
request line) kept ``Client`` waiting for minutes with a 10 s timeout, and one that answered
with other bytes made distributed read them as a frame length (3 EiB) and raise ``MemoryError``.
No option of distributed bounds the whole connection, so :func:`client_of` builds the client in
a thread of its own and waits for it at most ``timeout`` plus a margin.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any

from tensegrity_core.sweep.errors import SweepError

if TYPE_CHECKING:
    from distributed import Client

#: Seconds waited beyond ``timeout`` for distributed's own timeout error to arrive.
MARGIN_S = 2.0


def client_of(address: str, timeout: float) -> Client:
    """A client of the scheduler at ``address`` (e.g. ``tcp://host:8786``), connected within
    ``timeout`` seconds (+ :data:`MARGIN_S`), or :class:`SweepError` in one line naming the
    address: unreachable, silent, or not speaking Dask's protocol. A connection that completes
    after the wait was given up is closed by its thread (a daemon: it never holds the exit)."""
    from distributed import Client

    outcome: dict[str, Any] = {}
    given_up = threading.Event()

    def connect() -> None:
        try:
            client = Client(address, timeout=timeout)
        except BaseException as err:  # noqa: BLE001 - handed to the waiting thread, which says it in one line
            outcome["error"] = err
            return
        outcome["client"] = client
        if given_up.is_set():
            client.close()

    thread = threading.Thread(target=connect, name="dask-connect", daemon=True)
    thread.start()
    thread.join(timeout + MARGIN_S)
    given_up.set()
    if "client" in outcome:
        client: Client = outcome["client"]
        return client
    err = outcome.get("error")
    if err is None:
        raise SweepError(f"cannot reach the Dask scheduler at {address!r} within {timeout:g} s: something "
                         "accepted the connection but did not answer as a Dask scheduler")
    if isinstance(err, MemoryError):
        raise SweepError(f"cannot reach the Dask scheduler at {address!r}: what answered there does not speak "
                         "Dask's protocol")
    raise SweepError(f"cannot reach the Dask scheduler at {address!r} within {timeout:g} s: {err}")
