"""``tensegrity_ik``: the ``solve_ik`` service over the core's inverse kinematics.

Request ``(x, y, seed)``: the end-effector target D [m] and optionally the current
actuator lengths ``[rho1, rho2]`` [m]. Response: the valid solutions only, nearest the
seed first, each naming its nearest singular set and the distance to it (a solution on a
set, such as the folded pose for D = (0, L), is an equilibrium the controller refuses as a
target, and the message says so); ``success = false`` with a reason for unreachable,
non-finite or malformed requests. Parameters: ``scene`` (the mechanism's L, k1..k4 come from it, as for the
simulator and the controller) and ``paper_range``.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any

from rclpy.node import Node
from tensegrity_msgs.msg import IKSolution
from tensegrity_msgs.srv import SolveIK

from tensegrity_core.class2 import inverse_kinematics
from tensegrity_core.class2.inverse_kinematics import IKCandidate
from tensegrity_core.errors import TensegrityError
from tensegrity_ros.nodes.common import SERVICE_QOS, declare, spin_node
from tensegrity_ros.nodes.scene_param import scene_mechanism
from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services


class IKNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("tensegrity_ik", **kwargs)
        guard_parameter_services(self)
        self.params = scene_mechanism(self)
        self.paper_range = declare(
            self, "paper_range", True,
            "only solutions with 0 <= alpha, beta <= pi/2 (the paper's range) are valid",
            read_only=True)
        self.create_service(SolveIK, "solve_ik", self.on_request, qos_profile=SERVICE_QOS)
        self.get_logger().info(
            f"solve_ik ready (L = {self.params.L:g} m, paper_range = {self.paper_range})")

    def on_request(self, req: SolveIK.Request, res: SolveIK.Response) -> SolveIK.Response:
        res.success, res.message, res.solutions = False, "", []
        seed = list(req.seed)
        if len(seed) not in (0, 2):
            res.message = f"seed must be empty or [rho1, rho2], got {len(seed)} values"
            return res
        if not all(math.isfinite(v) for v in (req.x, req.y, *seed)):
            res.message = f"non-finite request: x = {req.x:g} m, y = {req.y:g} m, seed = {seed} m"
            return res
        try:
            result = inverse_kinematics(req.x, req.y, self.params, paper_range=self.paper_range)
        except TensegrityError as err:
            res.message = str(err)
            return res
        valid = list(result.valid)
        if seed:
            valid.sort(key=lambda c: math.hypot(c.rho1 - seed[0], c.rho2 - seed[1]))
        res.solutions = [self._to_msg(c, seed) for c in valid]
        res.success = bool(valid)
        res.message = result.message
        return res

    @staticmethod
    def _to_msg(c: IKCandidate, seed: list[float]) -> IKSolution:
        return IKSolution(
            rho1=c.rho1, rho2=c.rho2, beta=c.beta, alpha=c.alpha,
            delta1=int(c.delta1), delta2=int(c.delta2), in_paper_range=bool(c.in_paper_range),
            stiffness_beta=float(c.stiffness_beta),
            distance_to_seed=math.hypot(c.rho1 - seed[0], c.rho2 - seed[1]) if seed else 0.0,
            singularity_distance=float(c.singularity_distance),
            singular_set=c.singular_set,
        )


def main(argv: Sequence[str] | None = None) -> int:
    return spin_node(IKNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
