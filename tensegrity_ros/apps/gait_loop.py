"""Roll the running suite's robot a number of faces in closed loop (``tensegrity gait ROBOT
roll``; the command's checks are in :mod:`tensegrity_ros.cli.cmd_gait`).

A thin client around :class:`tensegrity_core.robot.roll_control.RollController`: it
subscribes to the simulator's ``body_states`` and ``contacts``, hands each stamped pair to
:class:`.gait_feedback.FeedbackLoop` (the mapping to the controller's inputs and the answers,
no ROS) and publishes its answers on ``cable_commands``, until the controller is done; then
it watches the robot come to rest and prints the summary of :mod:`.roll_summary`, as
:mod:`.gait_run` does for an open-loop gait.

Before the loop starts, the simulator's parameters say whether the loop can run: the scene
must simulate the robot with its motors taking commands, ``contacts`` must come with every
state (``state_rate`` at least ``publish_rate``), and a lockstep simulator must have no other
node answering its states on ``cable_commands`` (the suite's cable controller answers every
state too, and the simulator steps on the first answer: start the suite with
``--no-controller``). A free-running simulator takes every command in order, so there the
idle cable controller's empty answers change nothing.
"""

from __future__ import annotations

import sys
import time
from typing import Any, Final, TextIO

from tensegrity_core.sim.joint_trajectory import MAX_DURATION
from tensegrity_ros.apps.gait_feedback import ClockWentBack, FeedbackLoop, RodFrames
from tensegrity_ros.apps.gait_run import NS_PER_S, RunWatcher, SuiteError, check_scene, sim_parameters

#: The controller's rate [Hz] (the robots' usual 50 Hz control loop).
RATE = 50.0


def _other_answerers(node: Any, executor: Any, look: float, name_wait: float) -> list[str]:
    """The nodes other than ``node`` publishing ``cable_commands`` (fully qualified names),
    looked for in the graph for up to ``look`` s (DDS discovery of a node takes that long on a
    loaded machine). A publisher seen without its node's name (rmw's ``_UNKNOWN_`` until that
    node's participant has told its names, which can come seconds after its endpoints on a
    loaded machine) is waited for up to ``name_wait`` s more, then called "another node"."""
    topic = node.resolve_topic_name("cable_commands")
    me = node.get_fully_qualified_name()
    deadline = time.monotonic() + look
    name_by = 0.0                    # seen without a name: waited for until then
    while True:
        infos = node.get_publishers_info_by_topic(topic)
        names = sorted({f"{i.node_namespace.rstrip('/')}/{i.node_name}" for i in infos} - {me})
        named = [n for n in names if "_UNKNOWN_" not in n]     # rmw's placeholder until the node is known
        if named:
            return named
        now = time.monotonic()
        if names and not name_by:
            name_by = now + name_wait
        if now >= max(deadline, name_by):
            return ["another node"] if names else []
        executor.spin_once(timeout_sec=0.1)


def _second_answerer(others: list[str]) -> SuiteError:
    return SuiteError(f"the simulator runs in lockstep and {', '.join(others) or 'another node'} already answers its "
                      "states on cable_commands: the closed-loop gait must be the only one (start the suite with "
                      "`tensegrity up --no-controller`)")


def roll_closed_loop(robot_name: str, faces: int, heading: tuple[float, float], ros_args: list[str], *,
                     timeout: float, settle: float, max_time: float, out: TextIO = sys.stdout) -> int:
    """Roll ``robot_name`` ``faces`` faces towards ``heading`` (x, y on the floor) in closed loop
    on the running suite (module note); give up after ``max_time`` s of simulation time; watch
    up to ``settle`` s more until the robot is at rest; print the summary to ``out``. The exit
    code: 0 rolled exactly ``faces``, 1 not (or the suite cannot run it), 3 no simulator answers, 130 Ctrl-C."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile
    from std_msgs.msg import Header
    from tensegrity_msgs.msg import CableCommand, CapContacts, RigidBodyStates
    from tqdm import tqdm

    from tensegrity_core.robot.loading import load_robot
    from tensegrity_core.robot.roll_control import RollController
    from tensegrity_ros.cli.ros_clients import DISCOVERY_S, client_node
    from tensegrity_ros.nodes.sim.decimation import Decimation
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    robot = load_robot(robot_name)
    cables = tuple(robot.cables.names[j] for j in robot.cables.actuated)
    controller = RollController(robot, faces, heading=heading)
    loop = FeedbackLoop(controller, RodFrames.of(robot), robot.node_names, cables, rate=RATE)
    rclpy, node = client_node("tensegrity_gait", ros_args)
    joined = time.monotonic()      # discovery of the other answerers runs from here, beside the set-up below
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    watcher = RunWatcher(node)
    pub = node.create_publisher(CableCommand, "cable_commands", QoSProfile(depth=100))
    live = [False]                 # answer states only once the simulator hears the answers
    sent = [0]                     # answers published (our subscription to cable_commands sees them too)
    failure: list[str] = []
    last_state = [time.monotonic()]

    def send(answers: list[Any]) -> None:
        for a in answers:
            hdr = Header()
            hdr.stamp.sec, hdr.stamp.nanosec = divmod(a.stamp_ns, NS_PER_S)
            pub.publish(CableCommand(header=hdr, name=list(a.names), rest_length=list(a.rest_lengths)))
            sent[0] += 1

    def fed(call: Any) -> None:
        last_state[0] = time.monotonic()
        if live[0] and not failure:
            try:
                send(call())
            except ClockWentBack as err:
                failure.append(str(err))

    def on_bodies(msg: Any) -> None:
        stamp = msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec
        fed(lambda: loop.on_bodies(stamp, list(msg.name),
                                   [(p.position.x, p.position.y, p.position.z) for p in msg.pose],
                                   [(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w)
                                    for p in msg.pose]))

    def on_contacts(msg: Any) -> None:
        stamp = msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec
        fed(lambda: loop.on_contacts(stamp, list(msg.name)))

    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1000)
    node.create_subscription(RigidBodyStates, "body_states", on_bodies, qos)
    node.create_subscription(CapContacts, "contacts", on_contacts, qos)
    bar = None
    try:
        scene, lockstep, publish_rate, state_rate = sim_parameters(
            node, executor, ["scene", "lockstep", "publish_rate", "state_rate"], timeout)
        check_scene(scene.string_value, robot_name, cables)
        every = Decimation(publish_rate.double_value, {"contacts": state_rate.double_value}).every["contacts"]
        if every != 1:
            how = f"with every {every}th state" if every else "never"
            raise SuiteError(f"the simulator publishes contacts {how} (state_rate {state_rate.double_value:g} Hz, "
                             f"publish_rate {publish_rate.double_value:g} Hz): the closed-loop gait needs them with "
                             "every state (start it with -p state_rate:=<publish_rate>)")
        # matched by the watcher's own subscription and the simulator's
        if not wait_for_matches([pub], 2, timeout, poll=lambda s: executor.spin_once(timeout_sec=s)):
            raise SuiteError(f"the simulator does not subscribe to {pub.topic_name} within {timeout:g} s", code=3)
        # the graph has been discovered since the node joined it: DISCOVERY_S in all from then
        look = max(0.0, joined + DISCOVERY_S - time.monotonic())
        others = _other_answerers(node, executor, look, timeout) if lockstep.bool_value else []
        if others:
            raise _second_answerer(others)
        live[0] = True
        heard = watcher.controller_answers        # commands on the topic before the loop's first
        last_state[0] = time.monotonic()
        bar = tqdm(total=faces, unit="face", file=sys.stderr, dynamic_ncols=True, mininterval=0.5,
                   desc=f"rolling {robot_name} closed loop")
        while loop.done_ns is None and not failure:
            if loop.start_ns is not None and loop.elapsed() >= max_time:
                break
            if time.monotonic() - last_state[0] > timeout:
                raise SuiteError(f"no states from the simulator for {timeout:g} s (is it playing? "
                                 "`tensegrity sim play`)", code=3)
            executor.spin_once(timeout_sec=0.1)
            if lockstep.bool_value and watcher.controller_answers - heard > sent[0]:   # a node started since
                raise _second_answerer(_other_answerers(node, executor, timeout, timeout))    # it is there: heard
            if controller.rolled > bar.n:
                bar.update(controller.rolled - bar.n)
            bar.set_postfix_str(f"t = {loop.elapsed():.2f} s", refresh=False)
        bar.close()
        if failure:
            raise SuiteError(failure[0])
        start = (loop.start_ns or 0) / NS_PER_S
        finished = loop.done_ns is not None
        end = (loop.done_ns if loop.done_ns is not None else (loop.start_ns or 0) + round(loop.elapsed() * NS_PER_S)
               ) / NS_PER_S
        rest = watcher.watch_until_rest(executor, end, settle, timeout) if finished else None
        where = f"towards ({controller.heading[0]:+.2f}, {controller.heading[1]:+.2f})"
        ok = finished and controller.rolled == faces
        if ok:
            print(f"done: the controller rolled {faces} of {faces} faces {where} in {end - start:.2f} s "
                  f"of simulation time ({RATE:g} Hz closed loop)", file=out)
        elif finished:
            print(f"rolled too far: the controller counted {controller.rolled} faces, {faces} asked, {where} in "
                  f"{end - start:.2f} s of simulation time (the last tip carried the robot over the next edge)",
                  file=out)
        else:
            print(f"failed: the controller rolled {controller.rolled} of {faces} faces {where} in {max_time:g} s "
                  "of simulation time (--max-time); the motors hold their last rest lengths", file=out)
        stop = rest if rest is not None else (end + settle if finished else end)
        hull = [tuple(robot.node_names[i] for i in f) for f in controller.moves.faces]
        for line in watcher.summary_lines(start, stop, hull):
            print(f"  {line}", file=out)
        if finished:
            print(f"  {watcher.rest_line(end, settle, rest, after='the controller released the motors')}", file=out)
        return 0 if ok else 1
    except KeyboardInterrupt:
        print("stopped: the motors hold their last rest lengths", file=sys.stderr)
        return 130
    finally:
        if bar is not None:
            bar.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()


#: Simulation time [s] a face gets by default (a tip takes 1-2 s, a retry over another edge 3 s more).
FACE_TIME: Final = 10.0
#: The longest closed-loop roll [s of simulation time]: a day, the longest trajectory the
#: suite's cable controller accepts (:data:`tensegrity_core.sim.joint_trajectory.MAX_DURATION`).
MAX_TIME: Final = MAX_DURATION
#: The most faces one roll may ask for: each with its FACE_TIME within MAX_TIME (8640).
MAX_FACES: Final = int(MAX_TIME // FACE_TIME)


def default_max_time(faces: int) -> float:
    """Simulation time [s] the closed-loop roll gets by default: FACE_TIME a face, at least one
    FACE_TIME."""
    return FACE_TIME * max(1, faces)

