"""A recorder started just before a burst holds every message of it, even when it stalls for
the whole burst: the recorder reports its first message per topic and its matched
publishers (``tensegrity record``), the program waits for those
(:meth:`tensegrity_ros.apps.recording.Recorder.wait_ready`) and only then drives a lockstep
simulator as fast as it goes, while the recorder is stopped (SIGSTOP, as a loaded machine
would starve it); the writers' history holds what it missed, which it gets at their next
heartbeat (:meth:`~tensegrity_ros.apps.recording.Recorder.wait_complete`). Checked with the
independent MCAP reader (mcap-ros2-support) and with the completeness check the demo prints.
With the writers' former history of 100 samples this lost 99 of every topic's 301."""

from __future__ import annotations

import os
import signal

import pytest

from tests.bags.compare import read_with_mcap_ros2

pytestmark = pytest.mark.ros

STEP_NS = 10_000_000          # 10 ms
STEPS = 300                   # three times the depth the simulator's writers once kept


def _stamp(plain_msg) -> int:
    stamp = plain_msg["clock"] if "clock" in plain_msg else plain_msg["header"]["stamp"]
    return stamp["sec"] * 1_000_000_000 + stamp["nanosec"]


def test_a_recorder_started_just_before_a_burst_holds_every_message_of_it(cli, ros_context, tmp_path):
    import rclpy

    from tensegrity_ros.apps.recording import Recorder
    from tensegrity_ros.apps.sim_client import SimClient
    from tensegrity_ros.bag.completeness import completeness_line
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    sim = cli("node", "sim", "--ros-args", "-p", "lockstep:=true", "-p", "initial_state:=paused",
              "-p", f"step_size:={STEP_NS / 1e9}", "-p", "publish_rate:=100.0", "-p", "paused_publish_rate:=0.0",
              log_name="sim")
    sim.wait_for("publishing at")
    client = SimClient(rclpy, "burst_test", context=ros_context)
    rec = None
    try:
        client.wait_for_services(60)
        commands_before = client.pub.get_subscription_count()
        folder = tmp_path / "burst"
        rec = Recorder(folder, ["joint_states", "end_effector", "/clock", "actuator_forces", "events"])
        provoked = rec.wait_ready(["/joint_states", "/end_effector", "/clock"], client.reset_all,
                                  matched={"/actuator_forces": 1, "/events": 1}, every=0.2)
        assert provoked >= 1
        assert wait_for_matches([client.pub], commands_before + 1, 60)
        client.reset_all()
        client.take_joints()
        client.set_law(lambda sample: (0.5, -0.2), until_ns=STEPS * STEP_NS)
        os.kill(rec.proc.pid, signal.SIGSTOP)
        try:
            client.step(STEPS)                    # one request: the burst runs as fast as lockstep goes
            client.wait_joint(STEPS * STEP_NS)
        finally:
            os.kill(rec.proc.pid, signal.SIGCONT)
        run = set(range(0, (STEPS + 1) * STEP_NS, STEP_NS))
        missing = rec.wait_complete({"/joint_states": run, "/end_effector": run, "/clock": run,
                                     "/actuator_forces": run - {STEPS * STEP_NS}}, timeout=30.0)
        assert not any(missing.values()), {t: len(m) for t, m in missing.items()}
        assert rec.stop() == 0
        rec = None
    finally:
        if rec is not None:
            rec.stop()
        client.close()

    by_mcap = read_with_mcap_ros2(folder)
    for topic in ("/joint_states", "/end_effector", "/clock"):
        assert {_stamp(m) for _, _, m in by_mcap[topic]} >= run, topic
    commands = {_stamp(m) for _, _, m in by_mcap["/actuator_forces"]}
    assert not (run - {STEPS * STEP_NS}) - commands, f"commands missing: {sorted(run - commands)[:5]}"
    complete, line = completeness_line(folder, {"/joint_states": run, "/clock": run})
    assert complete and line.startswith("complete"), line
