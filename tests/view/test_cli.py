"""``tensegrity view`` as a user runs it: where it listens, its one-line errors, its stop."""

from __future__ import annotations

import http.client
import signal
import socket
import subprocess

import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from tests.ros.test_loopback import sockets_of
from tests.ros_support import TENSEGRITY, run_cli_here
from tests.view.support import MALFORMED, PATIENCE, foreign_roll, handshake, start_view, subprotocol


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([TENSEGRITY, "view", *args], capture_output=True, text=True, timeout=120)


def _refused(*args: str) -> subprocess.CompletedProcess:
    """``tensegrity view ARGS`` run in this process (:func:`~tests.ros_support.run_cli_here`):
    for the refusals made before anything listens, whose output is the view's own lines
    (no ROS, nothing written to the file descriptors below Python), no interpreter start."""
    return run_cli_here("view", *args)


def test_a_port_in_use_is_one_line_naming_it():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = _refused("--scene", "class2_at_rest", "--port", str(port))
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [f"error: port {port} on 127.0.0.1 is in use (another view or program "
                                               "listens there); choose another with --port"]


@pytest.mark.parametrize("args, message", [
    (("--scene", "no_such_scene"), "no_such_scene"),
    (("/nonexistent/bag",), "does not exist"),
    (("--scene", "class2_at_rest", "--port", "70000"), "must be in 0..65535"),
])
def test_bad_input_is_one_line(args, message):
    res = _refused(*args)
    assert res.returncode != 0 and "Traceback" not in res.stderr
    last = res.stderr.strip().splitlines()[-1]     # argparse prints its usage above the error line
    assert "error:" in last and message in last


def test_the_view_listens_on_loopback_only_and_serves_its_page_from_itself(cli):
    view, url, port = start_view(cli, "--scene", "class2_at_rest")
    listening = [(proto, addr, p) for proto, addr, p in sockets_of(view.popen.pid) if p == port]
    assert listening and all(addr == "127.0.0.1" for _proto, addr, _p in listening), listening
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    conn.request("GET", "/")
    page = conn.getresponse().read().decode()
    conn.close()
    assert "<html" in page and '<div id="root">' in page
    # the page names no address to load from: every src/href is relative or inline data
    assert "src=\"http" not in page and "href=\"http" not in page
    assert view.stop() == 0


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_ends_every_connection_of_the_page_and_its_server(cli, sig):
    """A browser's spare connection that has sent no request, a websocket client that
    neither reads nor answers the close, and one that does: the stop ends them all and the
    server's thread ends before the view exits (viser's one line). Left to ``websockets``,
    either of the first two held the server for 10 s (its open and close timeouts), longer
    than viser waits for it, and the view exited with the thread still running."""
    view, url, port = start_view(cli, "--scene", "class2_at_rest")
    spare = socket.create_connection(("127.0.0.1", port), timeout=PATIENCE)
    stalled = handshake(port)                      # accepted after the spare one: both are the server's now
    with connect(url.replace("http", "ws") + "/", subprotocols=[subprotocol()], open_timeout=PATIENCE) as page:
        page.recv(timeout=PATIENCE)                # the page's first message: the server sends to it
        assert view.stop(sig) == 0
        with pytest.raises(ConnectionClosed):
            while True:                            # what the server sent before it closed, then the close
                page.recv(timeout=PATIENCE)
    spare.close()
    stalled.close()
    assert view.popen.stdout.read() == "(viser) Server stopped\n"
    assert "Traceback" not in view.stderr() and len(view.stderr().strip().splitlines()) == 1


def test_another_host_is_warned_about_before_it_listens():
    """192.0.2.1 (TEST-NET-1, RFC 5737) is no address of this machine: the warning comes
    first, then the one-line error, and nothing listens anywhere but loopback meanwhile."""
    res = _refused("--scene", "class2_at_rest", "--host", "192.0.2.1", "--port", "8097")
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert lines[0] == ("warning: listening on 192.0.2.1: anyone who can reach this machine can watch and drive "
                        "the simulation")
    assert lines[-1].startswith("error: cannot listen on 192.0.2.1:8097")


def test_a_loopback_host_by_name_is_not_warned_about(cli):
    view, _url, _port = start_view(cli, "--scene", "class2_at_rest", "--host", "localhost")
    assert "warning" not in view.stderr()
    assert view.stop() == 0


def test_a_robot_bag_with_a_malformed_custom_data_plays_from_its_markers_or_says_what_is_missing(cli, tmp_path):
    """No --scene, a custom_data record that cannot be read: with the simulator's markers the
    view starts and says what draws the robot; without them, one line naming --scene NAME."""
    foreign_roll(tmp_path / "marked", MALFORMED, ("body_states", "cable_states", "contacts", "markers"), seconds=0.5)
    view, _url, _port = start_view(cli, str(tmp_path / "marked"))
    assert "/six_bar/markers" in view.stderr() and "drawn from its markers" in view.stderr()
    assert view.stop() == 0
    foreign_roll(tmp_path / "bare", MALFORMED, ("body_states", "cable_states"), seconds=0.5)
    res = _refused(str(tmp_path / "bare"))
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 1 and len(lines) == 1 and "Traceback" not in res.stderr
    assert "custom_data cannot be read" in lines[0] and "--scene NAME" in lines[0]


def test_no_suite_running_is_one_line_naming_the_topic():
    """``tensegrity view --wait 1`` with no simulator in its ROS domain (each test module runs
    in a domain of its own; none of this module's starts a suite): after the 1 s wait, one
    error line naming the topic it waited on and what to do, exit status 3."""
    res = _run("--wait", "1")
    assert res.returncode == 3 and "Traceback" not in res.stderr
    assert res.stderr.strip().splitlines() == ["error: no state on /mechanism_state within 1 s (is the suite up? "
                                               "`tensegrity up`; in a namespace: --namespace)"]
