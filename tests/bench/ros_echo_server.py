"""Bare rclpy baselines of the ROS benchmarks (what DDS and rclpy alone cost on this
machine): a service that answers std_srvs/Trigger at once (``bench_echo``, against
``solve_ik`` and ``StepSimulation``), and a topic echo that answers every
sensor_msgs/JointState on ``bench_ping`` with a command message of the same stamp on
``bench_pong`` (against the lockstep loop, which exchanges a joint state and a command):
by default a tensegrity_msgs/ActuatorForces of two forces; with ``--answer TYPE HEX`` the
message of that tensegrity_msgs type serialized in ``HEX`` (the lockstep controller's own
command, so both exchanges carry the same messages). The echo takes its pings as the
simulator takes its commands: a node of its own without parameter services, spun by no
executor, its subscription waited on and taken on a thread of its own
(:class:`~tensegrity_ros.rclpy_utils.inbox.Inbox`): the leanest rclpy answer is the fair
baseline."""

import argparse
import threading

import rclpy
import tensegrity_msgs.msg
from rclpy.executors import ExternalShutdownException
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from tensegrity_msgs.msg import ActuatorForces

from tensegrity_ros.rclpy_utils.inbox import Inbox


def main() -> None:
    ap = argparse.ArgumentParser(prog="python -m tests.bench.ros_echo_server")
    ap.add_argument("--answer", nargs=2, metavar=("TYPE", "HEX"),
                    help="answer with this serialized tensegrity_msgs message (default: ActuatorForces f1, f2)")
    args = ap.parse_args()
    kind, serialized = ActuatorForces, serialize_message(ActuatorForces(name=["f1", "f2"], force=[0.0, 0.0]))
    if args.answer:
        kind, serialized = getattr(tensegrity_msgs.msg, args.answer[0]), bytes.fromhex(args.answer[1])
    rclpy.init()
    node = rclpy.create_node("bench_echo_server")
    node.create_service(Trigger, "bench_echo", lambda req, res: res)
    echo = rclpy.create_node("bench_topic_echo", start_parameter_services=False)
    pong = echo.create_publisher(kind, "bench_pong", QoSProfile(depth=100))

    def answer(msg: JointState) -> None:
        out = deserialize_message(serialized, kind)      # a new message per answer, as a controller makes
        out.header.stamp = msg.header.stamp
        pong.publish(out)

    inbox = Inbox(echo)
    inbox.subscribe(JointState, "bench_ping", answer, QoSProfile(depth=100))
    stop = threading.Event()

    def take() -> None:
        while not stop.is_set():
            inbox.wait(0.1)

    taking = threading.Thread(target=take, name="bench_topic_echo")
    executor = rclpy.get_global_executor()
    executor.add_node(node)
    try:
        taking.start()
        print("echo ready", flush=True)
        # rclpy.spin's loop, each wait ending after 0.1 s: rclpy's SIGINT handling wakes the wait
        # before it shuts the context down, and its KeyboardInterrupt may come in no thread
        # (tensegrity_ros/rclpy_utils/stop_signals.py); an endless wait could then miss the stop
        while executor.context.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        stop.set()
        inbox.wake()
        if taking.is_alive():
            taking.join()           # joined: a thread still in rcl_wait at exit aborts the process
        executor.remove_node(node)
        echo.destroy_node()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
