"""Bare rclpy baselines of the ROS benchmarks (what DDS and rclpy alone cost on this
machine): a service that answers std_srvs/Trigger at once (``bench_echo``, against
``solve_ik`` and ``StepSimulation``), and a topic echo that answers every
sensor_msgs/JointState on ``bench_ping`` with a tensegrity_msgs/ActuatorForces of the same
stamp on ``bench_pong`` (against the lockstep loop, which exchanges those two types). The
echo is a node of its own without parameter services on an executor of its own, as the
simulator takes its commands: an rclpy executor's wake-up walks every entity of its nodes,
so the leanest rclpy answer is the fair baseline."""

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from tensegrity_msgs.msg import ActuatorForces

from tensegrity_ros.rclpy_utils.spin_thread import SpinThread


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("bench_echo_server")
    node.create_service(Trigger, "bench_echo", lambda req, res: res)
    echo = rclpy.create_node("bench_topic_echo", start_parameter_services=False)
    pong = echo.create_publisher(ActuatorForces, "bench_pong", QoSProfile(depth=100))

    def answer(msg: JointState) -> None:
        out = ActuatorForces(name=["f1", "f2"], force=[0.0, 0.0])
        out.header.stamp = msg.header.stamp
        pong.publish(out)

    echo.create_subscription(JointState, "bench_ping", answer, QoSProfile(depth=100))
    echo_executor = SingleThreadedExecutor()
    echo_executor.add_node(echo)
    spinning = SpinThread(echo_executor, "bench_topic_echo").start()
    print("echo ready", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        spinning.stop()             # joined: a thread still in rcl_wait at exit aborts the process
        echo_executor.shutdown()
        echo.destroy_node()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
