"""What the view answers a client it cannot read: an HTTP status, one log line, no traceback.

The view's HTTP side is ``websockets``' handshake parser (viser serves its page through it,
:mod:`.request_guard`). That parser takes only ``GET ... HTTP/1.1`` with at most 128 header
lines of at most 8192 bytes each and no body; on anything else it closes the connection
without a word and logs the parse error with its traceback. Here such a request is answered
before the connection closes (:func:`status_for`):

====================================================  =========================================
request                                               answer
====================================================  =========================================
a method other than GET (POST, HEAD, PUT, OPTIONS)    405 Method Not Allowed, ``Allow: GET``
a request line over 8192 bytes                        414 URI Too Long
a header line over 8192 bytes, over 128 header lines  431 Request Header Fields Too Large
a protocol other than HTTP/1.1 (HTTP/1.0)             505 HTTP Version Not Supported
a body, a transfer coding, a malformed line           400 Bad Request
====================================================  =========================================

and the log keeps one line per such request (:class:`QuietHandshakeFailures`), quoting the
request's words as an excerpt (escaped, at most about 120 characters). A request cut
short by its client (the connection closed mid-request) gets no answer: no one reads it.

On the websocket, viser decodes each frame as a msgpack message of its own and lets any
frame it cannot decode (text, garbage bytes, an unknown message type) end the connection
handler with a traceback (a close with code 1011, "internal error"). :func:`guarded_consumer`
closes such a connection with 1007 (invalid frame payload data) and one log line instead;
other clients are not affected either way.
"""

from __future__ import annotations

import http
import logging
import traceback
from collections.abc import Callable, Coroutine
from typing import Any, Final

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed, InvalidMessage, SecurityError
from websockets.frames import CloseCode
from websockets.http11 import MAX_LINE_LENGTH, MAX_NUM_HEADERS
from websockets.protocol import CONNECTING
from websockets.server import ServerProtocol

from tensegrity_core.excerpt import excerpt

LOGGER: Final = logging.getLogger("tensegrity_ros.view")


def status_for(error: BaseException | None) -> tuple[http.HTTPStatus, str] | None:
    """The status and one-line reason answering a request whose parse raised ``error``
    (the module docstring's table), or None when the client closed mid-request."""
    if error is None or isinstance(error, EOFError):
        return None
    text = str(error)
    if isinstance(error, SecurityError):
        if "too many" in text:
            return http.HTTPStatus.REQUEST_HEADER_FIELDS_TOO_LARGE, f"over {MAX_NUM_HEADERS} header lines"
        in_headers = any(frame.f_code.co_name == "parse_headers" for frame, _ in traceback.walk_tb(error.__traceback__))
        if in_headers:
            return http.HTTPStatus.REQUEST_HEADER_FIELDS_TOO_LARGE, f"a header line over {MAX_LINE_LENGTH} bytes"
        return http.HTTPStatus.REQUEST_URI_TOO_LONG, f"a request line over {MAX_LINE_LENGTH} bytes"
    if text.startswith("unsupported HTTP method"):
        return http.HTTPStatus.METHOD_NOT_ALLOWED, "the view answers GET only"
    if text.startswith("unsupported protocol"):
        return http.HTTPStatus.HTTP_VERSION_NOT_SUPPORTED, "the view speaks HTTP/1.1 only"
    return http.HTTPStatus.BAD_REQUEST, "not a request the view reads (a GET without a body)"


def _answer(status: http.HTTPStatus, reason: str) -> bytes:
    body = f"tensegrity view: {status.value} {status.phrase}: {reason}\n".encode()
    allow = "Allow: GET\r\n" if status == http.HTTPStatus.METHOD_NOT_ALLOWED else ""
    head = (f"HTTP/1.1 {status.value} {status.phrase}\r\nConnection: close\r\n{allow}"
            f"Content-Type: text/plain; charset=utf-8\r\nContent-Length: {len(body)}\r\n\r\n")
    return head.encode() + body


class _AnsweringProtocol(ServerProtocol):
    """websockets' server protocol, answering an unparseable request before it closes."""

    def send_eof(self) -> None:
        failed = self.handshake_exc if self.state is CONNECTING else None
        cause = failed.__cause__ if isinstance(failed, InvalidMessage) else None
        answer = status_for(cause)
        if answer is not None:
            self.writes.append(_answer(*answer))
            LOGGER.warning("tensegrity view: answered %d to an unreadable request (%s)", answer[0].value,
                           excerpt(str(cause), 120))
        super().send_eof()


class AnsweringConnection(ServerConnection):
    """The connection factory (``serve(create_connection=...)``) whose protocol answers
    unparseable requests (:func:`status_for`)."""

    def __init__(self, protocol: ServerProtocol, *args: Any, **kwargs: Any):
        protocol.__class__ = _AnsweringProtocol     # the same object, one method added
        super().__init__(protocol, *args, **kwargs)


class QuietHandshakeFailures(logging.Filter):
    """Drops websockets' "opening handshake failed" record (a traceback) of a request that
    could not be parsed: it was answered and logged in one line, or its client left."""

    def filter(self, record: logging.LogRecord) -> bool:
        error = record.exc_info[1] if record.exc_info else None
        return not (record.getMessage() == "opening handshake failed" and isinstance(error, InvalidMessage))


Consumer = Callable[[Any, Callable[[Any], None], type], Coroutine[Any, Any, None]]


def guarded_consumer(consume: Consumer) -> Consumer:
    """viser's incoming-message loop ``consume(websocket, handle, message_class)``, closing
    the connection with 1007 and one log line on a frame it cannot decode."""

    async def guarded(websocket: Any, handle: Callable[[Any], None], message_class: type) -> None:
        try:
            await consume(websocket, handle, message_class)
        except ConnectionClosed:
            raise
        except Exception as err:     # viser's decode of a frame: msgspec, KeyError, an assert, ...
            LOGGER.warning("tensegrity view: closed a websocket client that sent a frame the page never sends "
                           "(%s: %s)", type(err).__name__, excerpt(str(err), 120))
            await websocket.close(CloseCode.INVALID_DATA, "not a viser message")
            await websocket.recv()   # raises ConnectionClosed, which viser's handler ends on quietly
    return guarded
