"""The demo's robot phase: the 6-bar rolled a number of faces in closed loop over ROS,
recorded, rerun identical.

A second ``tensegrity_sim`` runs the scene ``six_bar_rest`` (the 6-bar standing on a face,
its 24 motors taking ``cable_commands``) in the namespace ``/six_bar``, in lockstep and
paused, with the demo's control period as its step. The demo's client is the closed-loop
rolling gait of ``tensegrity gait six_bar roll`` (:class:`.gait_feedback.FeedbackLoop` over
the core's ``RollController``): it answers every state with the controller's rest lengths
from the state's ``contacts`` and ``body_states``, until ``faces`` faces are rolled (stepped
in chunks of ``CHUNK_S``, then ``SETTLE_S`` more to settle). The run is recorded to
``OUT/six_bar_roll`` (every topic the simulator publishes, and the commands), then run a
second time and compared stamp by stamp (identical bit for bit: lockstep stepping depends
on no arrival time, and the controller on nothing but the states). What the robot did:
distance [m], faces rolled, peak tensions [N] (:mod:`.roll_summary`, from the client's own
subscriptions).
"""

from __future__ import annotations

import shutil
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tensegrity_core.sim.sampled import NS_PER_S
from tensegrity_ros.rclpy_utils.messages import stamp_ns

NAMESPACE = "/six_bar"
SCENE = "six_bar_rest"
FACES = 3                 # the demo stays short
BAG = "six_bar_roll"
#: s of simulation time stepped at a time until the controller is done, then to settle
CHUNK_S = 0.5
SETTLE_S = 1.0


class LoopFeeder:
    """The client's subscriptions to ``body_states`` and ``contacts`` feeding ``loop`` (None:
    not answering), its answers published on ``pub`` once per stamp and only below
    ``until_ns`` [ns] (an answer to a run's final state would reach the simulator after the
    next reset, stamped for another step); every sample (with ``joint_states``) also goes to
    ``watcher`` (a :class:`.gait_run.RunWatcher` made without subscriptions of its own to
    them). The samples are taken on a thread of their own from a node that no executor spins
    (:class:`~tensegrity_ros.rclpy_utils.inbox.Inbox`): through the client's executor, each of
    the five per step cost a wake-up that rebuilds the wait set of the client's node.

    What the loop sees depends on no thread's timing, so that a rerun is identical:

    - the reset's state at t = 0, published before the loop starts, is answered when it
      starts (dropped, the lockstep simulator would wait out its timeout for that command);
    - of each kind, only the messages from its t = 0 state on are fed (a topic's messages
      arrive in order, so a late state of the run before the reset comes before it);
    - :meth:`wait_fed` lets the caller wait until the loop has had a stamp, so that the
      loop's ``done_ns`` is read after the last state of a chunk of steps (read before it,
      a run could step a chunk more than its rerun)."""

    def __init__(self, node: Any, pub: Any, watcher: Any) -> None:
        from rclpy.qos import HistoryPolicy, QoSProfile
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Header
        from tensegrity_msgs.msg import CableCommand, CapContacts, RigidBodyStates

        from tensegrity_ros.rclpy_utils.inbox import InboxThread

        self.loop: Any = None
        self.until_ns: int | None = None
        self._answered: set[int] = set()
        self._fed_cv = threading.Condition()          # callbacks on the spin thread, the rest on the caller's
        self._at_reset: dict[str, Any] = {}           # body_states and contacts stamped t = 0 since start(None)
        self._fed: set[tuple[str, int]] = set()       # what the loop has had: a reset's state comes once
        self._pub, self._Header, self._CableCommand = pub, Header, CableCommand
        self._watcher = watcher
        self._samples = InboxThread(node, "samples")
        qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1000)    # the watcher loses no sample
        inbox = self._samples.inbox
        inbox.subscribe(RigidBodyStates, node.resolve_topic_name("body_states"), self._on_bodies, qos)
        inbox.subscribe(CapContacts, node.resolve_topic_name("contacts"), self._on_contacts, qos)
        inbox.subscribe(JointState, node.resolve_topic_name("joint_states"), watcher._on_joints, qos)
        self._samples.start()

    def close(self) -> None:
        self._samples.close()

    def start(self, loop: Any) -> None:
        with self._fed_cv:
            self.loop, self.until_ns, self._answered, self._fed = loop, None, set(), set()
            if loop is None:
                self._at_reset = {}
            for kind, msg in self._at_reset.items():
                self._feed(kind, msg)

    def _on_bodies(self, msg: Any) -> None:
        self._watcher._on_bodies(msg)
        self._give("bodies", msg)

    def _on_contacts(self, msg: Any) -> None:
        self._watcher._on_contacts(msg)
        self._give("contacts", msg)

    def _give(self, kind: str, msg: Any) -> None:
        with self._fed_cv:
            if stamp_ns(msg.header.stamp) == 0:
                self._at_reset[kind] = msg
            if self.loop is not None and kind in self._at_reset:
                self._feed(kind, msg)

    def wait_fed(self, stamp_ns: int, timeout: float = 60.0) -> None:
        """Wait until the loop has had both kinds stamped ``stamp_ns`` [ns]."""
        with self._fed_cv:
            if not self._fed_cv.wait_for(lambda: {("bodies", stamp_ns), ("contacts", stamp_ns)} <= self._fed, timeout):
                raise RuntimeError(f"the 6-bar's body_states and contacts stamped {stamp_ns / NS_PER_S:g} s did not "
                                   f"reach the gait within {timeout:g} s")

    def _feed(self, kind: str, msg: Any) -> None:
        """Give the loop ``msg`` once per kind and stamp (every reset's state at t = 0 is the
        same state)."""
        if (kind, stamp_ns(msg.header.stamp)) in self._fed:
            return
        self._fed.add((kind, stamp_ns(msg.header.stamp)))
        self._fed_cv.notify_all()
        if kind == "bodies":
            self._send(self.loop.on_bodies(stamp_ns(msg.header.stamp), list(msg.name),
                                           [(p.position.x, p.position.y, p.position.z) for p in msg.pose],
                                           [(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w)
                                            for p in msg.pose]))
        else:
            self._send(self.loop.on_contacts(stamp_ns(msg.header.stamp), list(msg.name)))

    def _send(self, answers: list[Any]) -> None:
        for a in answers:
            if a.stamp_ns in self._answered or (self.until_ns is not None and a.stamp_ns >= self.until_ns):
                continue
            self._answered.add(a.stamp_ns)
            hdr = self._Header()
            hdr.stamp.sec, hdr.stamp.nanosec = divmod(a.stamp_ns, NS_PER_S)
            self._pub.publish(self._CableCommand(header=hdr, name=list(a.names), rest_length=list(a.rest_lengths)))




def run_robot(rclpy: Any, out: Path, *, step_ns: int, record: bool, results: dict[str, Any], bags: list[Path],
              say: Callable[[str], None], faces: int = FACES) -> bool:
    """The robot phase (module note); True when the rerun is identical and the bag complete."""
    from tensegrity_core.robot.loading import load_robot
    from tensegrity_core.robot.roll_control import RollController, TipMoves
    from tensegrity_ros.apps.gait_feedback import FeedbackLoop, RodFrames
    from tensegrity_ros.apps.gait_loop import RATE, default_max_time
    from tensegrity_ros.apps.gait_run import RunWatcher
    from tensegrity_ros.apps.launch import Launcher, ProcessSpec
    from tensegrity_ros.apps.recording import Recorder
    from tensegrity_ros.apps.sim_client import SimClient
    from tensegrity_ros.bag.completeness import completeness_line
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    robot = load_robot("six_bar")
    cables = tuple(robot.cables.names[j] for j in robot.cables.actuated)
    moves, frames = TipMoves(robot), RodFrames.of(robot)
    chunk, settle = round(CHUNK_S * NS_PER_S) // step_ns, round(SETTLE_S * NS_PER_S) // step_ns
    most = -(-round(default_max_time(faces) * NS_PER_S) // step_ns)
    exe = [sys.executable, "-m", "tensegrity_ros.cli"]
    argv = exe + ["node", "sim", "--ros-args", "-r", f"__ns:={NAMESPACE}", "-p", f"scene:={SCENE}",
                  "-p", "lockstep:=true", "-p", "initial_state:=paused", "-p", f"step_size:={step_ns / NS_PER_S!r}",
                  "-p", f"publish_rate:={NS_PER_S / step_ns!r}", "-p", "paused_publish_rate:=0.0",
                  "-p", f"state_rate:={NS_PER_S / step_ns!r}",                 # contacts with every state
                  "-p", "lockstep_timeout:=30.0", "-p", "publish_clock:=false"]
    log = open(out / "six_bar.log", "w")
    launcher = Launcher([ProcessSpec("six_bar", argv)], out=log)
    say(f"the 6-bar robot: {SCENE} in {NAMESPACE}, lockstep at {step_ns / 1e6:g} ms, rolled {faces} faces towards +x "
        f"by the closed-loop gait (`tensegrity gait six_bar roll`: contacts and rod poses in, rest lengths out at "
        f"{RATE:g} Hz), then {SETTLE_S:g} s to settle; logs in {out / 'six_bar.log'}")
    launcher.start()
    client = SimClient(rclpy, "tensegrity_demo_six_bar", namespace=NAMESPACE, record_events=False, cables=cables)
    watcher = RunWatcher(client.node, samples=False)
    feeder = LoopFeeder(client.node, client.pub, watcher)
    rec = None
    try:
        client.wait_for_services(120.0)

        def roll() -> tuple[int, list[Any]]:
            feeder.start(None)
            client.set_law(None)
            client.restart()
            loop = FeedbackLoop(RollController(robot, faces, moves=moves), frames, robot.node_names, cables,
                                rate=RATE)
            feeder.start(loop)
            k = 0
            while loop.done_ns is None and k < most:
                client.step(chunk)
                k += chunk
                feeder.wait_fed(k * step_ns)
            feeder.until_ns = (k + settle) * step_ns
            client.step(settle)
            k += settle
            feeder.start(None)
            client.wait_joint(k * step_ns)
            return k, client.take_joints()

        if record:
            folder = out / BAG
            if folder.exists():
                shutil.rmtree(folder)
            published = sorted(name for name, _ in client.node.get_topic_names_and_types()
                               if name.startswith(NAMESPACE + "/") and client.node.count_publishers(name) > 0
                               and not name.endswith("/cable_commands") and "/_" not in name)
            commands_before = client.pub.get_subscription_count()
            rec = Recorder(folder, [*published, f"{NAMESPACE}/cable_commands", "--custom-data", f"scene={SCENE}"])
            state = [t for t in published if not t.endswith("/events")]
            rec.wait_ready(state, client.reset_all, matched={f"{NAMESPACE}/cable_commands": 1}, every=0.2)
            if not wait_for_matches([client.pub], commands_before + 1, 60.0):
                raise RuntimeError("the demo's cable_commands publisher did not match the recorder within 60 s")
            bags.append(folder)
        say("  rolling the 6-bar" + (f" (recording {out / BAG})" if record else ""))
        steps, first = roll()
        window = (0.0, steps * step_ns / NS_PER_S)
        drained = time.monotonic() + 30.0        # the watcher's samples up to the run's end (its own subscriptions)
        while watcher.latest() < window[1] and time.monotonic() < drained:
            time.sleep(0.05)
        complete = True
        if rec is not None:
            stamps = sorted({j.stamp_ns for j in first})
            expected = {f"{NAMESPACE}/joint_states": stamps, f"{NAMESPACE}/body_states": stamps,
                        f"{NAMESPACE}/cable_commands": stamps[:-1]}
            rec.wait_complete(expected)
            code, rec = rec.stop(), None
            complete, line = completeness_line(folder, expected)
            complete = complete and code == 0
            say(f"  bag {folder}: {line}")
        summary = watcher.summary_lines(*window)
        for text in summary:
            say(f"  {text}")
        say("  the roll again, not recorded: same lockstep run, compared stamp by stamp")
        _, second = roll()
        a, b = {j.stamp_ns: j for j in first}, {j.stamp_ns: j for j in second}
        identical = a == b
        say(f"  second run: {len(b)} joint states, " + ("identical to the first (every cable length, rate and "
                                                        "tension bit for bit)" if identical else "DIFFERENT"))
        results["robot"] = {"identical": identical, "complete": complete, "summary": summary}
        return identical and complete
    finally:
        if rec is not None:
            rec.stop()
        feeder.close()
        client.close()
        launcher.stop()
        log.close()
