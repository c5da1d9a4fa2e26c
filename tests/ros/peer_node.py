"""A small real node run as a separate process by the ROS smoke test.

It echoes ``ping`` (tensegrity_msgs/ActuatorForces) to ``pong`` with every force doubled,
and serves ``solve_ik`` (tensegrity_msgs/SolveIK) answering one solution whose rho1, rho2
are the request's x, y (a transport check, not kinematics). With ``PEER_LISTENER=1`` in its
environment, ``ping`` is taken by a second node of the process, ``smoke_peer_listener``,
that has no parameter services (as the simulator's command node), on a thread of its own.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading

from tensegrity_ros.rclpy_utils.env import require_rclpy

require_rclpy()                  # one clear line when the ROS wheels are missing
from rclpy.node import Node  # noqa: E402
from tensegrity_msgs.msg import ActuatorForces, IKSolution  # noqa: E402
from tensegrity_msgs.srv import SolveIK  # noqa: E402

from tensegrity_ros.nodes.common import spin_node  # noqa: E402
from tensegrity_ros.rclpy_utils.inbox import Inbox  # noqa: E402


class Peer(Node):
    def __init__(self) -> None:
        super().__init__("smoke_peer")
        self.pub = self.create_publisher(ActuatorForces, "pong", 10)
        if os.environ.get("PEER_LISTENER") == "1":
            listener = Node("smoke_peer_listener", namespace=self.get_namespace(), context=self.context,
                            start_parameter_services=False)
            inbox = Inbox(listener)
            inbox.subscribe(ActuatorForces, "ping", self.on_ping, 10)
            threading.Thread(target=self._take, args=(inbox,), daemon=True).start()
        else:
            self.create_subscription(ActuatorForces, "ping", self.on_ping, 10)
        self.create_service(SolveIK, "solve_ik", self.on_ik)

    def _take(self, inbox: Inbox) -> None:
        with contextlib.suppress(Exception):       # the context's shutdown ends the wait
            while True:
                inbox.wait(0.1)

    def on_ping(self, msg: ActuatorForces) -> None:
        out = ActuatorForces(header=msg.header, name=list(msg.name), force=[2.0 * f for f in msg.force])
        self.pub.publish(out)

    def on_ik(self, req: SolveIK.Request, res: SolveIK.Response) -> SolveIK.Response:
        res.success = True
        res.message = "echo"
        res.solutions = [IKSolution(rho1=req.x, rho2=req.y)]
        return res


def _ready_peer() -> Peer:
    node = Peer()
    print("ready", flush=True)
    return node


def main() -> int:
    """Spun as the suite's nodes are (``spin_node``): SIGTERM from the test is a stop request
    that wakes the executor, so the peer ends promptly however busy the machine is."""
    return spin_node(_ready_peer, sys.argv)


if __name__ == "__main__":
    sys.exit(main())
