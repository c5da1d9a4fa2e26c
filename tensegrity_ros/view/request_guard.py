"""The view's Host and Origin check: a page from another site never reads or drives the view.

A server on 127.0.0.1 is out of reach of other machines, not of other *pages* in the user's
own browser. Two attacks use the browser as the bridge:

- **DNS rebinding**: a page at ``http://evil.example:8080`` has its name re-resolved to
  127.0.0.1, so its scripts reach the view with the browser's same-origin blessing; its
  requests carry ``Host: evil.example:8080``.
- **Cross-site websocket**: any page may open ``ws://127.0.0.1:8080`` (websockets are not
  bound by the same-origin policy); the handshake carries that page's ``Origin``.

So every request, the page's files and the websocket upgrade alike, is checked before viser
answers it (:func:`refusal`): its ``Host`` must name this server by address (an IP literal,
which no rebinding can produce), as ``localhost`` or by this machine's own name (names an
attacker's DNS does not control), with the port it was accepted on. An
``Origin``, when present (browsers send one with every websocket and cross-origin request),
must be the same ``http://host:port`` as the ``Host``. A request without an ``Origin``
(curl, a script) is a program on this machine or one the user let in with ``--host``.

viser (1.1.1, pinned) has no hook for this: its HTTP handler is a closure passed as
``process_request`` to ``websockets.asyncio.server.serve`` inside its server thread
(``viser/infra/_infra.py``). :func:`install` therefore hands viser's module a view of the
``websockets`` package whose ``serve`` wraps that ``process_request`` with the check and
answers requests websockets cannot parse (:mod:`.unreadable_clients`, which also guards
viser's incoming-message loop); nothing else in the process, websockets included, is changed. :func:`guarding` tells
whether viser's server was started through the wrapper, so a viser that no longer goes
through it is refused at start rather than run without the check.
"""

from __future__ import annotations

import functools
import http
import ipaddress
import socket
import threading
from collections.abc import Callable
from typing import Any, Final
from urllib.parse import urlsplit

from tensegrity_core.excerpt import excerpt

#: Names that mean this machine's loopback address.
LOCAL_NAMES: Final = ("localhost", "localhost.")


def _split_host(value: str) -> tuple[str, int | None] | None:
    """``(host, port)`` of a ``Host`` header value (``[::1]:8080``, ``127.0.0.1``); None if malformed."""
    try:
        parts = urlsplit(f"//{value}")
        return (parts.hostname or "").lower(), parts.port
    except ValueError:
        return None


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def _own_names() -> set[str]:
    return {socket.gethostname().lower(), socket.getfqdn().lower()}


def refusal(host: str | None, origin: str | None, local_address: tuple[str, int]) -> str | None:
    """Why a request with these ``Host`` and ``Origin`` headers, accepted on the socket at
    ``local_address`` (address, port), is refused, or None to serve it (module docstring)."""
    address, port = local_address[0], int(local_address[1])
    named = _split_host(host or "")
    if named is None or not named[0]:
        return "no valid Host header"
    name, host_port = named
    if (host_port or 80) != port:
        return f"Host {host!r} names another port than {port}"
    if not (_is_ip(name) or name in LOCAL_NAMES or name in _own_names()):
        return (f"Host {host!r} is not this view's address (a page of another site: refused); "
                f"open http://{address if ':' not in address else f'[{address}]'}:{port}")
    if origin is not None:
        parts = urlsplit(origin)
        try:
            same = (parts.scheme, (parts.hostname or "").lower(), parts.port or 80) == ("http", name, port)
        except ValueError:
            same = False
        if not same:
            return f"Origin {origin!r} is another site than {host!r}"
    return None


_state = {"installed": False, "serving": False}
_lock = threading.Lock()


def _text(status: http.HTTPStatus, line: str) -> Any:
    """A response of ``status`` whose body is ``line`` (plain text, one line)."""
    from websockets.datastructures import Headers
    from websockets.http11 import Response

    body = f"tensegrity view: {line}\n".encode()
    return Response(status.value, status.phrase,
                    Headers({"Content-Type": "text/plain; charset=utf-8", "Content-Length": str(len(body))}), body)


def _guarded(process_request: Callable[..., Any] | None, connection: Any, request: Any) -> Any:
    """Refuse a request that :func:`refusal` refuses (403, one line); else viser's handler,
    whose 404 (no body) gets one line of text saying what is not there."""
    reason = refusal(request.headers.get("Host"), request.headers.get("Origin"), connection.local_address[:2])
    if reason is not None:
        return _text(http.HTTPStatus.FORBIDDEN, reason)
    response = process_request(connection, request) if process_request is not None else None
    if response is not None and response.status_code == http.HTTPStatus.NOT_FOUND and not response.body:
        path = excerpt(urlsplit(request.path).path, 120)
        return _text(http.HTTPStatus.NOT_FOUND, f"404 Not Found: {path} is not a file of the view's page (it is at /)")
    return response


class _Namespace:
    """An object whose attributes are ``target``'s except the ``overrides``."""

    def __init__(self, target: Any, overrides: dict[str, Any]):
        self._target = target
        self._overrides = overrides

    def __getattr__(self, name: str) -> Any:
        if name in self._overrides:
            return self._overrides[name]
        return getattr(self._target, name)


def install() -> None:
    """Put the check in front of every request of viser's servers in this process, and
    :mod:`.unreadable_clients`' answers after it (once)."""
    import logging

    import websockets
    import websockets.asyncio.server as ws_server
    from viser.infra import _infra

    from tensegrity_ros.view import prompt_stop, unreadable_clients

    with _lock:
        if _state["installed"]:
            return

        @functools.wraps(ws_server.serve)
        def serve(*args: Any, process_request: Callable[..., Any] | None = None, **kwargs: Any) -> Any:
            _state["serving"] = True
            return prompt_stop.PromptServe(*args, process_request=functools.partial(_guarded, process_request),
                                           create_connection=unreadable_clients.AnsweringConnection, **kwargs)

        server = _Namespace(ws_server, {"serve": serve})
        # the name viser's module calls websockets.asyncio.server.serve through (its own global only)
        vars(_infra)["websockets"] = _Namespace(websockets, {"asyncio": _Namespace(websockets.asyncio,
                                                                                  {"server": server})})
        vars(_infra)["_message_consumer"] = unreadable_clients.guarded_consumer(_infra._message_consumer)
        logging.getLogger("websockets.server").addFilter(unreadable_clients.QuietHandshakeFailures())
        _state["installed"] = True


def guarding() -> bool:
    """Whether a viser server has been started through the check since :func:`install`."""
    return _state["serving"]
