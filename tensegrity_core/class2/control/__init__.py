"""Actuator-force control of the class-2 mechanism (docs/control.md).

- :class:`TrackingController`: feedforward along a :class:`Reference` plus gain-scheduled
  discrete LQR feedback on the linearised dynamics, with an integral of the end-effector
  error (anti-windup) and a force limit;
- references: :func:`plan_move` (D along a straight line, IK-checked, dynamically
  consistent), :func:`end_effector_reference` (any end-effector path),
  :func:`actuator_reference` (a timed trajectory of rho1, rho2 with the interpolation of
  control_msgs' JointTrajectory), :func:`hold_reference`;
- :func:`holding_forces`, :func:`rest_state`; the model's linearisation
  (:func:`linearize`, :func:`discretize`, :func:`design_gain`);
- :class:`ActuatorTracker`: the demo's present PD law, the benchmarks' baseline.
"""

from tensegrity_core.class2.control.baseline import ActuatorTracker
from tensegrity_core.class2.control.errors import (
    INVALID_GOAL,
    INVALID_JOINTS,
    OUTSIDE_WORKSPACE,
    SINGULAR_PATH,
    PlanningError,
)
from tensegrity_core.class2.control.flat import end_effector_reference
from tensegrity_core.class2.control.holding import holding_forces, rest_state
from tensegrity_core.class2.control.law import ScheduledGains, Tick, TrackingController, schedule_gains
from tensegrity_core.class2.control.lqr import Gain, LQRWeights, augment, design_gain, discretize, linearize
from tensegrity_core.class2.control.paths import PEAK_SPEED_FACTOR, CirclePath, LinePath, smooth_step
from tensegrity_core.class2.control.planner import SINGULAR_MARGIN, check_path_ik, move_duration, plan_move
from tensegrity_core.class2.control.reference import Reference, ReferenceSample, hold_reference

__all__ = [
    "ActuatorTracker", "CirclePath", "Gain", "INVALID_GOAL", "INVALID_JOINTS", "LQRWeights", "LinePath",
    "OUTSIDE_WORKSPACE", "PEAK_SPEED_FACTOR", "PlanningError", "Reference", "ReferenceSample", "SINGULAR_MARGIN",
    "SINGULAR_PATH", "ScheduledGains", "Tick", "TrackingController", "augment", "check_path_ik", "design_gain",
    "discretize", "end_effector_reference", "hold_reference", "holding_forces", "linearize", "move_duration",
    "plan_move", "rest_state", "schedule_gains", "smooth_step",
]
