"""Loopback only (issue 12): with the discovery range LOCALHOST every socket of every suite
process is bound to a loopback address, the processes still find each other, and data
between them still goes through shared memory (as with rmw_fastrtps's own LOCALHOST set-up).

Under LOCALHOST rmw_fastrtps sends only to 127.0.0.1 but binds its UDP sockets to 0.0.0.0
and to the machine's outward address; the suite's Fast DDS profile
(``tensegrity_ros/rclpy_utils/fastdds_loopback.xml``, selected by ``ensure_ros_environment``) binds
them to 127.0.0.1. The sockets of a process are read from ``/proc/<pid>/net/{udp,udp6,
tcp,tcp6}`` (all sockets of the network namespace) joined with the socket inodes among
``/proc/<pid>/fd``.
"""

from __future__ import annotations

import ipaddress
import os
import socket
import struct
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from tests.process_groups import kill_group, wait_exited
from tests.ros_support import TENSEGRITY, spawn

pytestmark = [pytest.mark.ros,
              pytest.mark.skipif(not Path("/proc/self/net/udp").exists(), reason="needs Linux /proc")]

SAMPLE_BAG = Path(__file__).resolve().parents[2] / "bags" / "ik_motion"


def _address(hex_addr: str) -> str:
    """The local address field of /proc/net/{udp,tcp}[6] (little-endian words)."""
    raw = bytes.fromhex(hex_addr)
    if len(raw) == 4:
        return socket.inet_ntop(socket.AF_INET, struct.pack("<I", struct.unpack(">I", raw)[0]))
    words = b"".join(struct.pack("<I", struct.unpack(">I", raw[i:i + 4])[0]) for i in range(0, 16, 4))
    return socket.inet_ntop(socket.AF_INET6, words)


def sockets_of(pid: int) -> list[tuple[str, str, int]]:
    """(protocol, local address, port) of every IP socket process ``pid`` holds."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(int(target[8:-1]))
    out = []
    for proto in ("udp", "udp6", "tcp", "tcp6"):
        for line in Path(f"/proc/{pid}/net/{proto}").read_text().splitlines()[1:]:
            fields = line.split()
            if int(fields[9]) in inodes:
                addr, port = fields[1].split(":")
                out.append((proto, _address(addr), int(port, 16)))
    return out


def _processes_marked(mark: str) -> list[int]:
    pids = []
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                if mark.encode() in Path(entry.path, "environ").read_bytes().split(b"\0"):
                    pids.append(int(entry.name))
            except OSError:
                pass
    return pids


def _peer_segments() -> set[str]:
    """Fast DDS shared-memory segments (not port files) this process has mapped."""
    import re

    return set(re.findall(r"/dev/shm/(fastrtps_[0-9a-f]{16})\b", Path("/proc/self/maps").read_text()))


def _cmd(pid: int) -> str:
    """The ``tensegrity`` subcommand of process ``pid`` without its ROS arguments (``up``,
    ``node sim``; ``pytest`` for this process), or its command line."""
    if pid == os.getpid():
        return "pytest"
    cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    for program in ("tensegrity_ros.cli ", "bin/tensegrity "):
        if program in cmd:
            return cmd.split(program, 1)[1].split(" --ros-args")[0][:200]
    return cmd[:200]


def test_every_socket_of_the_suite_is_on_loopback_and_the_nodes_still_meet(tmp_path, ros_context):
    import rclpy
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState

    from tensegrity_ros.rclpy_utils.raw_take import take_all

    mark = f"TENSEGRITY_SOCKET_TEST={uuid.uuid4().hex}"
    env = dict(os.environ, **dict([mark.split("=", 1)]))
    log = tmp_path / "up.log"
    procs = []
    with open(log, "w") as out:
        procs.append(spawn([TENSEGRITY, "up", "--record", str(tmp_path / "bag")], env=env,
                           stdout=out, stderr=out))
        procs.append(spawn([TENSEGRITY, "play", str(SAMPLE_BAG), "--loop", "--topics", "/markers",
                            "--ros-args", "-r", "/markers:=/replayed_markers"],
                           env=env, stdout=out, stderr=out))
        try:
            probe = rclpy.create_node("loopback_probe", context=ros_context)
            segments_before = _peer_segments()     # this process's own, before any data
            sub = probe.create_subscription(JointState, "/joint_states", lambda *_: None,
                                            QoSProfile(depth=10), raw=True)
            wanted = {"/solve_ik", "/find_form", "/reset"}
            deadline = time.monotonic() + 90
            got_joints = False
            while True:       # every node discovered across processes, data flowing
                got_joints = got_joints or bool(take_all(sub))
                services = {name for name, _ in probe.get_service_names_and_types()}
                topics = {name for name, _ in probe.get_topic_names_and_types()}
                if got_joints and wanted <= services and "/replayed_markers" in topics:
                    break
                assert time.monotonic() < deadline, (log.read_text()[-3000:], services, topics)
                time.sleep(0.05)
            # the joint states came through shared memory: the simulator's segment is mapped
            # here now (data over UDP would map nothing new)
            assert _peer_segments() - segments_before, "no shared-memory segment of a peer"
            pids = _processes_marked(mark) + [os.getpid()]
            found = {pid: sockets_of(pid) for pid in pids}
            names = {pid: _cmd(pid) for pid in pids}       # while they live
            probe.destroy_node()
        finally:
            for p in procs:
                p.send_signal(2)
            for p in procs:
                try:
                    wait_exited(p, 30)
                finally:
                    kill_group(p)
    participants = {pid: socks for pid, socks in found.items() if socks}
    # sim, ik, formfind, recorder, player and this process hold DDS sockets
    print("\nIP sockets per process: " + "; ".join(
        f"{names[pid]}: {len(socks)} ({', '.join(sorted({f'{proto} {addr}' for proto, addr, _ in socks}))})"
        for pid, socks in sorted(found.items(), key=lambda item: names[item[0]])))
    assert len(participants) >= 6, {names[p]: s for p, s in found.items()}
    outside = {(pid, proto, addr, port) for pid, socks in participants.items()
               for proto, addr, port in socks if not ipaddress.ip_address(addr).is_loopback}
    assert not outside, sorted(outside)
    # the recorder, in its own process, received the simulator's joint states
    from tensegrity_ros.bag.reader import BagReader

    counts = {t.name: t.message_count for t in BagReader(tmp_path / "bag").topics()}
    assert counts.get("/joint_states", 0) > 0, counts


def test_the_suite_meets_a_plain_localhost_ros_process(tmp_path):
    """A ROS process outside the suite's profile (plain rmw LOCALHOST, as any ros2 tool the
    user runs) and a suite node find each other in both directions' discovery."""
    env = {k: v for k, v in os.environ.items() if k != "FASTRTPS_DEFAULT_PROFILES_FILE"}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    code = ("import rclpy, sys, time\n"
            "from sensor_msgs.msg import JointState\n"
            "rclpy.init(); n = rclpy.create_node('plain_localhost_listener'); got = []\n"
            "n.create_subscription(JointState, '/joint_states', got.append, 10)\n"
            "end = time.monotonic() + 60\n"
            "while not got and time.monotonic() < end: rclpy.spin_once(n, timeout_sec=0.1)\n"
            "print('received' if got else 'nothing'); n.destroy_node(); rclpy.shutdown()\n")
    with open(tmp_path / "sim.log", "w") as out:
        sim = spawn([TENSEGRITY, "node", "sim"], stdout=out, stderr=out, env=dict(os.environ))
        try:
            listener = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                                      text=True, timeout=120)
        finally:
            sim.send_signal(2)
            try:
                wait_exited(sim, 30)
            finally:
                kill_group(sim)
    assert listener.stdout.strip() == "received", listener.stderr[-2000:]
