"""The view's server stops within :data:`STOP_GRACE_S` whatever its clients do.

viser stops its server the way ``websockets`` closes one: no new connections, every open
websocket closed with code 1001 (going away), then a wait for every connection's handler
to end. Two kinds of client made that wait last seconds after a browser had visited:

- a connection that has sent no request yet. Browsers open spare connections to a page's
  server for requests to come (Chromium keeps one after loading the page); ``websockets``
  waits for its request until ``open_timeout`` (10 s) from its accept. A stop 6 s after a
  page loaded took 4 s: the rest of those 10 s.
- a websocket client that neither reads nor answers the close: ``websockets`` waits for
  its answer until ``close_timeout`` (10 s), or for ever while the close frame cannot be
  written because the client's socket buffers are full.

viser waits 6 s for its server thread, then returns with the thread still running.
:class:`PromptServe` (``websockets``' ``serve``, as viser uses it) therefore closes each
connection as its state allows when the server stops: one still in its opening handshake
at once (it holds no page), an open websocket with code 1001 and :data:`STOP_GRACE_S` for
its client's answer. After that grace every connection left is cut (TCP reset).
"""

from __future__ import annotations

import asyncio
from types import TracebackType
from typing import Final

from websockets.asyncio.server import ServerConnection, serve
from websockets.protocol import CONNECTING

#: Seconds an open websocket's client has to answer the server's close when the view stops;
#: a browser answers within milliseconds, a stalled client is then cut.
STOP_GRACE_S: Final = 0.5


class PromptServe(serve):
    """``websockets.asyncio.server.serve`` whose exit ends every connection within
    :data:`STOP_GRACE_S` (the module docstring)."""

    async def __aexit__(self, exc_type: type[BaseException] | None, exc_value: BaseException | None,
                        traceback: TracebackType | None) -> None:
        server = self.server
        server.server.close()                         # no new connections from here on
        for connection in tuple(server.handlers):
            if connection.protocol.state is CONNECTING:
                connection.transport.abort()
        cut = asyncio.get_running_loop().call_later(STOP_GRACE_S, _cut, tuple(server.handlers))
        try:
            await super().__aexit__(exc_type, exc_value, traceback)
        finally:
            cut.cancel()


def _cut(connections: tuple[ServerConnection, ...]) -> None:
    """Reset the TCP connections still open (their clients did not answer in time)."""
    for connection in connections:
        connection.transport.abort()
