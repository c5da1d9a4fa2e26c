"""The one error class of the control package: a goal the controller refuses."""

from __future__ import annotations

from tensegrity_core.errors import TensegrityError

#: Why a goal is refused (the ``code`` of :class:`PlanningError`); the ROS actions map
#: these onto their result codes.
INVALID_GOAL = "invalid_goal"            # malformed or non-finite input, durations <= 0, force limit
INVALID_JOINTS = "invalid_joints"        # joint names other than rho1, rho2
OUTSIDE_WORKSPACE = "outside_workspace"  # the target or the path leaves the reachable set
SINGULAR_PATH = "singular_path"          # the path passes through or near a singular set


class PlanningError(TensegrityError, ValueError):
    """A goal cannot be planned; ``code`` says why (one of the constants above) and the
    message names the offending value."""

    def __init__(self, message: str, *, code: str = INVALID_GOAL):
        super().__init__(message)
        self.code = code
