"""Bare rclpy baselines of the ROS benchmarks (what DDS and rclpy alone cost on this
machine): a service that answers std_srvs/Trigger at once (``bench_echo``, against
``solve_ik`` and ``StepSimulation``), and a topic echo that answers every
sensor_msgs/JointState on ``bench_ping`` with a tensegrity_msgs/ActuatorForces of the same
stamp on ``bench_pong`` (against the lockstep loop, which exchanges those two types)."""

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from tensegrity_msgs.msg import ActuatorForces


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("bench_echo_server")
    node.create_service(Trigger, "bench_echo", lambda req, res: res)
    pong = node.create_publisher(ActuatorForces, "bench_pong", QoSProfile(depth=100))

    def answer(msg: JointState) -> None:
        out = ActuatorForces(name=["f1", "f2"], force=[0.0, 0.0])
        out.header.stamp = msg.header.stamp
        pong.publish(out)

    node.create_subscription(JointState, "bench_ping", answer, QoSProfile(depth=100))
    print("echo ready", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
