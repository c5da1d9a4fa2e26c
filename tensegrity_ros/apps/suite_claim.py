"""A claim on one namespace of one ROS domain, held by a running ``tensegrity up`` on this host.

Looking at the DDS graph (:mod:`tensegrity_ros.apps.suite_presence`) can only see a suite
that discovery has shown within the look; under load that takes seconds, and a suite not
yet shown is not absent. Two ``up`` on one machine need no discovery to meet: the first
holds a claim here for as long as its launcher lives, and the second finds it at once,
whatever the load, and reads the first one's node names from it.

The claim is a listening Unix socket in the abstract namespace (Linux), named after the
domain and the namespace. Why a socket and not a lock file: the kernel releases it when its
holder ends, however it ends (a SIGKILLed launcher leaves nothing stale behind), and its
scope is the network namespace, the scope of the suite's loopback-only DDS (two suites in
separate network namespaces never discover each other, and their claims never meet either).
The holder answers each connection with its node names, one per line (UTF-8; a ROS name
has no line break), and closes it.

Where abstract sockets do not exist, :func:`claim` claims nothing and the graph look is the
only check.
"""

from __future__ import annotations

import hashlib
import socket
import sys
import threading
import time

#: How long [s] a second ``up`` waits for the holder's answer (it answers at once; the bound
#: only keeps a stopped holder, SIGSTOP, from hanging the second ``up``).
ANSWER_S = 2.0
#: The longest answer [bytes] read from a claim's holder (a suite's node names take ~200).
ANSWER_BYTES = 65536
#: What the refusal names when the holder did not answer within :data:`ANSWER_S`.
UNNAMED = "the nodes of another `tensegrity up` on this machine"


def _address(domain: int, namespace: str) -> bytes:
    """The claim's abstract socket address for ``namespace`` (absolute) of ROS domain
    ``domain`` (a digest: a namespace may be longer than a socket address)."""
    digest = hashlib.sha256(f"{domain}\0{namespace}".encode()).hexdigest()[:40]
    return b"\0tensegrity-up-" + digest.encode()


class SuiteClaim:
    """The claim held by this process: it answers other ``up`` with ``nodes`` (full node
    names) until :meth:`release` or the process's end. ``sock`` None: a claim that holds
    nothing (no abstract sockets on this platform)."""

    def __init__(self, sock: socket.socket | None, nodes: list[str]) -> None:
        self._sock = sock
        self._answer = "\n".join(sorted(nodes)).encode()
        if sock is not None:
            threading.Thread(target=self._serve, args=(sock,), name="suite-claim", daemon=True).start()

    def _serve(self, sock: socket.socket) -> None:
        while True:
            try:
                conn, _ = sock.accept()
            except OSError:                  # released
                return
            with conn:
                try:
                    conn.sendall(self._answer)
                except OSError:              # the asker is gone: nothing to answer
                    pass

    def release(self) -> None:
        """Give the claim up (another ``up`` may take it at once)."""
        if self._sock is None:
            return
        try:
            self._sock.shutdown(socket.SHUT_RDWR)      # wakes the serving thread's accept
        except OSError:
            pass
        self._sock.close()
        self._sock = None


def claim(domain: int, namespace: str, nodes: list[str]) -> SuiteClaim | list[str]:
    """Claim ``namespace`` (absolute) of ROS domain ``domain`` for a suite of ``nodes``
    (full names): the held claim, or the node names of the suite on this host that holds it
    already (then nothing is claimed; :data:`UNNAMED` if its holder does not answer within
    :data:`ANSWER_S`)."""
    if not sys.platform.startswith("linux"):
        return SuiteClaim(None, nodes)
    address = _address(domain, namespace)
    deadline = time.monotonic() + ANSWER_S
    while True:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            sock.bind(address)
        except OSError:
            sock.close()
        else:
            sock.listen(8)
            return SuiteClaim(sock, nodes)
        answer = _ask(address, deadline)
        if answer is not None:
            return answer
        if time.monotonic() >= deadline:
            return [UNNAMED]
        time.sleep(0.02)                     # bound but not listening yet, or just released


def _ask(address: bytes, deadline: float) -> list[str] | None:
    """The node names the holder of ``address`` answers with; None if nothing listens there
    (its holder has just bound it, or has just released it); :data:`UNNAMED` if it does not
    answer by ``deadline`` (a stopped holder) or answers no names."""
    data = b""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        try:
            sock.settimeout(max(0.01, deadline - time.monotonic()))
            sock.connect(address)
            while chunk := sock.recv(ANSWER_BYTES):
                data += chunk
                if len(data) > ANSWER_BYTES or time.monotonic() >= deadline:
                    return [UNNAMED]         # not a claim's answer: the address is taken all the same
                sock.settimeout(max(0.01, deadline - time.monotonic()))
        except ConnectionRefusedError:
            return None
        except OSError:                      # timed out, or the holder went away meanwhile
            return [UNNAMED]
    nodes = data.decode("utf-8", "replace").split("\n")
    return nodes if all(nodes) else [UNNAMED]
