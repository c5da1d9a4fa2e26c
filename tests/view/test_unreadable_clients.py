"""The view's HTTP side against bad input, over real sockets: every request it cannot read
gets an HTTP status and one log line, a websocket client sending garbage or leaving
mid-frame is closed alone, nothing outside the page's folder is served, and the server
goes on serving others through all of it."""

from __future__ import annotations

import http.client
import logging
import os
import socket
from concurrent.futures import ThreadPoolExecutor

import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from tensegrity_ros.view.server import start_server
from tests.view.support import PATIENCE, handshake, subprotocol

SUBPROTOCOL = subprotocol()


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


class Served:
    """A started view server on a free port, and every log record of its process."""

    def __init__(self) -> None:
        self._log = _Records()
        logging.getLogger().addHandler(self._log)
        self.server = start_server(port=0)
        self.port = self.server.get_port()
        self.stopped = False

    def raw(self, data: bytes) -> bytes:
        """What the server answers ``data`` sent on a fresh connection, until it closes."""
        with socket.create_connection(("127.0.0.1", self.port), timeout=PATIENCE) as s:
            s.sendall(data)
            out = b""
            while chunk := s.recv(65536):
                out += chunk
            return out

    def get(self, path: str = "/") -> tuple[int, bytes]:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=PATIENCE)
        conn.request("GET", path)
        res = conn.getresponse()
        body = res.read()
        conn.close()
        return res.status, body

    def stop(self) -> list[logging.LogRecord]:
        """Stop the server (its connections' handlers end first) and return its log."""
        if not self.stopped:
            self.server.stop()
            logging.getLogger().removeHandler(self._log)
            self.stopped = True
        return self._log.records


@pytest.fixture
def served():
    s = Served()
    yield s
    s.stop()


def _no_traceback(records: list[logging.LogRecord]) -> list[str]:
    return [f"{r.name}: {r.getMessage()}" for r in records if r.exc_info or r.levelno >= logging.ERROR]


def _request(line: bytes, *headers: bytes, body: bytes = b"") -> bytes:
    return line + b"\r\nHost: 127.0.0.1\r\n" + b"".join(h + b"\r\n" for h in headers) + b"\r\n" + body


BAD_REQUESTS = [
    ("POST", _request(b"POST / HTTP/1.1", b"Content-Length: 3", body=b"abc"), 405),
    ("HEAD", _request(b"HEAD / HTTP/1.1"), 405),
    ("PUT", _request(b"PUT /index.html HTTP/1.1"), 405),
    ("OPTIONS *", _request(b"OPTIONS * HTTP/1.1"), 405),
    ("HTTP/1.0", _request(b"GET / HTTP/1.0"), 505),
    ("garbage", b"\x00\x01\x02\xff garbage\r\n\r\n", 400),
    ("no version", b"GET /\r\n\r\n", 400),
    ("malformed header", _request(b"GET / HTTP/1.1", b"no colon here"), 400),
    ("a body", _request(b"GET / HTTP/1.1", b"Content-Length: 4", body=b"abcd"), 400),
    ("chunked body", _request(b"GET / HTTP/1.1", b"Transfer-Encoding: chunked", body=b"0\r\n\r\n"), 400),
    ("100 kB request line", _request(b"GET /" + b"a" * 100_000 + b" HTTP/1.1"), 414),
    ("100 kB header", _request(b"GET / HTTP/1.1", b"X-Big: " + b"y" * 100_000), 431),
    ("500 headers", _request(b"GET / HTTP/1.1", *(b"X-%d: y" % i for i in range(500))), 431),
]


def test_unreadable_requests_get_a_status_and_one_log_line_and_the_page_is_still_served(served):
    answers = {name: served.raw(data) for name, data, _ in BAD_REQUESTS}
    assert served.get("/")[0] == 200
    records = served.stop()
    for name, _, status in BAD_REQUESTS:
        head, _, body = answers[name].partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 %d " % status), (name, answers[name][:200])
        assert body.startswith(b"tensegrity view: %d " % status) and body.count(b"\n") == 1, (name, body)
        assert (b"Allow: GET" in head) == (status == 405), (name, head)
    assert _no_traceback(records) == []
    answered = [r.getMessage() for r in records if "answered" in r.getMessage()]
    assert len(answered) == len(BAD_REQUESTS), answered


def test_the_log_line_quotes_a_request_bounded_and_escaped(served):
    """A request line of 8000 bytes with a terminal escape in it: the log line is about 200
    characters and holds no control character (it cannot rewrite the user's terminal)."""
    answer = served.raw(b"\x1b[2J" + b"x" * 8000 + b"\r\n\r\n")
    assert answer.startswith(b"HTTP/1.1 400 ")
    (line,) = [r.getMessage() for r in served.stop() if "answered" in r.getMessage()]
    assert len(line) < 250 and "\x1b" not in line and "\\x1b" in line


def test_unknown_paths_are_404_with_one_line_saying_so_and_query_strings_are_ignored(served):
    for path in ("/no/such/file.js?x=1", "/assets", "/..%2f\x1b[2J"):      # a folder is not a file
        answer = served.raw(b"GET %s HTTP/1.1\r\nHost: 127.0.0.1:%d\r\n\r\n" % (path.encode(), served.port))
        head, _, body = answer.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 404 Not Found\r\n"), answer
        assert b"\r\nContent-Type: text/plain; charset=utf-8" in head
        assert b"\r\nContent-Length: %d" % len(body) in head
        assert body.startswith(b"tensegrity view: 404 Not Found: '/") and body.endswith(b"(it is at /)\n")
        assert body.count(b"\n") == 1 and b"\x1b" not in body and b"x=1" not in body
    status, body = served.get("/?x=1&y=%ZZ&z")
    assert status == 200 and b'<div id="root">' in body


#: ``package.json`` beside the page's folder (viser/client/build) in viser's wheel.
ESCAPES = ["/../package.json", "/assets/../../package.json", "/%2e%2e/package.json", "/%2E%2E%2Fpackage.json",
           "/..%2fpackage.json", "/..%5cpackage.json", "/..\\package.json", "/.%2e/package.json",
           "//../package.json", "/%2f..%2fpackage.json", "/../../../../../../etc/passwd", "/%2fetc%2fpasswd"]


@pytest.mark.parametrize("path", ESCAPES)
def test_nothing_outside_the_pages_folder_is_served(served, path):
    import viser

    outside = os.path.join(os.path.dirname(viser.__file__), "client", "package.json")
    assert os.path.isfile(outside)            # the file a traversal would reach exists
    answer = served.raw(b"GET %s HTTP/1.1\r\nHost: 127.0.0.1:%d\r\n\r\n" % (path.encode(), served.port))
    assert answer.startswith(b"HTTP/1.1 404 "), answer[:200]
    assert b'"name"' not in answer and b"root:" not in answer


@pytest.mark.parametrize("frame", [b"\x00garbage", "a text frame", b"\x81\xa4type\xa4Nope"])
def test_a_websocket_client_sending_garbage_is_closed_alone(served, frame):
    url = f"ws://127.0.0.1:{served.port}/"
    with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=PATIENCE) as other, \
            connect(url, subprotocols=[SUBPROTOCOL], open_timeout=PATIENCE) as bad:
        bad.send(frame)
        with pytest.raises(ConnectionClosed) as closed:
            while True:
                bad.recv(timeout=PATIENCE)
        assert closed.value.rcvd.code == 1007           # invalid frame payload data, not 1011
        other.ping().wait(PATIENCE)                      # the other client is still served
    assert served.get("/")[0] == 200
    records = served.stop()
    assert _no_traceback(records) == []
    assert sum("closed a websocket client" in r.getMessage() for r in records) == 1


def test_a_websocket_client_leaving_mid_frame_is_forgotten_quietly(served):
    s = handshake(served.port)
    s.sendall(b"\x82\xfe\x10\x00" + os.urandom(4) + b"part of 4096 bytes")   # masked, length 4096
    s.close()
    assert served.get("/")[0] == 200
    assert _no_traceback(served.stop()) == []         # stop() waits for every connection's handler


def test_many_clients_at_once_and_stalled_ones_do_not_block_the_page(served):
    stalled = []
    for _ in range(30):                                  # each holds a connection mid-request
        s = socket.create_connection(("127.0.0.1", served.port), timeout=PATIENCE)
        s.sendall(b"GET / HTTP/1.1\r\nHo")
        stalled.append(s)
    try:
        with ThreadPoolExecutor(8) as pool:
            answers = list(pool.map(lambda _: served.get("/"), range(16)))
        assert [status for status, _ in answers] == [200] * 16
        assert len({body for _, body in answers}) == 1
    finally:
        for s in stalled:
            s.close()
    assert _no_traceback(served.stop()) == []
