"""`tensegrity up`'s claim on a namespace of a ROS domain (tensegrity_ros/apps/suite_claim.py):
a second claim on this machine gets the holder's node names at once, whatever the load;
another namespace or domain is free; the claim ends with its holder, however it ends. Plain
sockets, no ROS: about 1 s of CPU for the module (two Python children), 2 s of waiting."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid

import pytest

from tensegrity_ros.apps.suite_claim import ANSWER_S, UNNAMED, SuiteClaim, claim

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="abstract Unix sockets are Linux's")

#: A child that claims ``/<argv[1]>`` of domain 7, says so, and sleeps.
HOLDER = ("import sys, time; from tensegrity_ros.apps.suite_claim import claim; "
          "held = claim(7, '/' + sys.argv[1], ['/' + sys.argv[1] + '/tensegrity_sim']); "
          "print(type(held).__name__, flush=True); time.sleep(600)")


@pytest.fixture
def namespace() -> str:
    """A namespace no other test (nor another run on this machine) claims."""
    return f"/claim_{uuid.uuid4().hex}"


@pytest.fixture
def holder(namespace):
    """A separate process holding the claim on ``namespace`` of domain 7."""
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, namespace.lstrip("/")], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "SuiteClaim"
    yield proc
    proc.kill()
    proc.wait()


def test_a_second_claim_gets_the_holders_node_names_and_claims_nothing(holder, namespace):
    assert claim(7, namespace, [f"{namespace}/tensegrity_ik"]) == [f"{namespace}/tensegrity_sim"]
    assert claim(7, namespace, []) == [f"{namespace}/tensegrity_sim"]      # still the holder's


def test_another_namespace_or_domain_is_free(holder, namespace):
    for domain, ns in ((7, namespace + "_b"), (8, namespace), (7, "/")):
        held = claim(domain, ns, [f"{ns}/tensegrity_sim"])
        assert isinstance(held, SuiteClaim), (domain, ns, held)
        held.release()


def test_a_released_claim_is_free_at_once_and_names_its_nodes_sorted_while_held(namespace):
    first = claim(3, namespace, [f"{namespace}/tensegrity_sim", f"{namespace}/tensegrity_ik"])
    assert isinstance(first, SuiteClaim)
    assert claim(3, namespace, []) == [f"{namespace}/tensegrity_ik", f"{namespace}/tensegrity_sim"]
    first.release()
    first.release()                                  # a second release changes nothing
    again = claim(3, namespace, [])
    assert isinstance(again, SuiteClaim)
    again.release()


def test_a_killed_holders_claim_is_free_at_once(holder, namespace):
    holder.send_signal(signal.SIGKILL)
    holder.wait()
    held = claim(7, namespace, [])
    assert isinstance(held, SuiteClaim)
    held.release()


def test_a_stopped_holder_is_refused_unnamed_after_the_answer_bound(holder, namespace):
    """A holder that cannot answer (SIGSTOP) still holds the namespace: the asker refuses
    after ANSWER_S without names instead of hanging or starting a second suite."""
    holder.send_signal(signal.SIGSTOP)
    os.waitpid(holder.pid, os.WUNTRACED)    # every thread of it stopped (a signal is delivered later)
    try:
        start = time.monotonic()
        assert claim(7, namespace, []) == [UNNAMED]
        assert time.monotonic() - start < ANSWER_S + 5.0      # a hang guard, not a timing claim
    finally:
        holder.send_signal(signal.SIGCONT)


def test_an_endless_answer_is_read_only_to_its_bound(namespace):
    """Whatever holds the address and answers without end (not a claim's holder) is read up
    to ANSWER_BYTES, within ANSWER_S: the namespace counts as taken, unnamed."""
    import socket
    import threading

    from tensegrity_ros.apps.suite_claim import _address

    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(_address(5, namespace))
    server.listen(1)

    def flood() -> None:
        conn, _ = server.accept()
        with conn:
            try:
                while True:
                    conn.sendall(b"x" * 4096)
            except OSError:
                pass

    thread = threading.Thread(target=flood, daemon=True)
    thread.start()
    try:
        assert claim(5, namespace, []) == [UNNAMED]
    finally:
        server.close()
        thread.join(10)
