"""The view refuses requests of other sites' pages (DNS rebinding, cross-site websockets):
real HTTP requests and websocket handshakes against a running view server."""

from __future__ import annotations

import http.client
import warnings

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from tensegrity_ros.view.request_guard import refusal
from tensegrity_ros.view.server import start_server

LOOPBACK = ("127.0.0.1", 8080)


@pytest.mark.parametrize("host, origin", [
    ("127.0.0.1:8080", None), ("localhost:8080", None), ("127.0.0.1:8080", "http://127.0.0.1:8080"),
    ("localhost:8080", "http://localhost:8080"), ("LOCALHOST:8080", "http://localhost:8080"),
])
def test_the_pages_own_host_and_origin_pass(host, origin):
    assert refusal(host, origin, LOOPBACK) is None


@pytest.mark.parametrize("host, origin, why", [
    ("evil.example:8080", None, "not this view's address"),              # DNS rebinding
    ("evil.example:8080", "http://evil.example:8080", "not this view's address"),
    ("127.0.0.1:8080", "http://evil.example", "another site"),          # a cross-site websocket
    ("127.0.0.1:8080", "http://127.0.0.1:9999", "another site"),        # another local server's page
    ("127.0.0.1:8080", "null", "another site"),                         # a sandboxed or file: page
    ("127.0.0.1:9999", None, "another port"),
    ("127.0.0.1", None, "another port"),                                # port 80 implied
    (None, None, "no valid Host"), ("", None, "no valid Host"), ("[::1", None, "no valid Host"),
])
def test_other_sites_are_refused(host, origin, why):
    assert why in refusal(host, origin, LOOPBACK)


def test_a_view_on_another_address_is_reached_by_its_address_or_the_machines_name():
    import socket

    local = ("192.168.1.5", 8080)
    assert refusal("192.168.1.5:8080", "http://192.168.1.5:8080", local) is None
    assert refusal(f"{socket.gethostname()}:8080", None, local) is None
    assert refusal("evil.example:8080", None, local) is not None


@pytest.fixture(scope="module")
def started():
    """A view server on a free port, and every warning its start-up raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = start_server(port=0)
    yield s, caught
    s.stop()


@pytest.fixture
def server(started):
    return started[0]


def test_the_server_starts_without_a_warning(started):
    """The view uses the installed viser's current API (no deprecated call, e.g. the
    control panel's placement)."""
    assert [f"{w.category.__name__}: {w.message}" for w in started[1]] == []


def _get(port: int, host: str, origin: str | None = None) -> tuple[int, str]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    headers = {"Host": host} | ({"Origin": origin} if origin else {})
    conn.request("GET", "/", headers=headers)
    res = conn.getresponse()
    body = res.read().decode()
    conn.close()
    return res.status, body


def test_a_page_request_with_a_foreign_host_is_refused_and_the_own_one_served(server):
    port = server.get_port()
    status, body = _get(port, f"evil.example:{port}")
    assert status == 403 and body.startswith("tensegrity view: Host") and body.count("\n") == 1
    status, body = _get(port, f"127.0.0.1:{port}", f"http://127.0.0.1:{port}")
    assert status == 200 and '<div id="root">' in body


def test_a_websocket_from_another_site_is_refused_and_the_pages_own_accepted(server):
    port = server.get_port()
    url = f"ws://127.0.0.1:{port}/"
    for origin in ("http://evil.example", f"http://evil.example:{port}"):
        with pytest.raises(InvalidStatus) as refused:
            connect(url, origin=origin, open_timeout=60)
        assert refused.value.response.status_code == 403
    with pytest.raises(InvalidStatus):               # the rebinding page's own Host
        connect(f"ws://127.0.0.1:{port}/", additional_headers={"Host": f"evil.example:{port}"},
                origin=f"http://evil.example:{port}", open_timeout=60)
    with connect(url, origin=f"http://127.0.0.1:{port}", open_timeout=60) as ws:   # the handshake is accepted
        assert ws.response.status_code == 101
