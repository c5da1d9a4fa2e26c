"""A bare rclpy service that answers std_srvs/Trigger at once: the baseline of the
``solve_ik`` round-trip benchmark (what DDS and rclpy alone cost on this machine)."""

import rclpy
from rclpy.executors import ExternalShutdownException
from std_srvs.srv import Trigger


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("bench_echo_server")
    node.create_service(Trigger, "bench_echo", lambda req, res: res)
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
