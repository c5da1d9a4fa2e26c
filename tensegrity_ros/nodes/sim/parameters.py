"""The simulator node's parameters: declared once, typed, described, range-checked, and
handed on as one frozen :class:`SimParameters` (all read-only at run time)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

from tensegrity_ros.nodes.common import ParameterValueError, declare
from tensegrity_ros.nodes.sim.control import STATE_BY_NAME
from tensegrity_ros.nodes.sim.sender import NS_PER_S

if TYPE_CHECKING:
    from rclpy.node import Node

#: A parameter's type, that of its default.
T = TypeVar("T", bool, int, float, str)


@dataclass(frozen=True)
class SimParameters:
    scene: str
    publish_rate: float         # [Hz] free-running ticks
    real_time_factor: float     # simulated s per wall s; 0 = as fast as possible
    step_ns: int                # the step (control period) [ns]
    lockstep: bool
    lockstep_timeout: float     # [s] wall time per step
    lockstep_real_time_factor: float  # lockstep, playing: at most this many simulated s per wall s; 0 = unpaced
    initial_state: int          # SimulationState value
    paused_publish_rate: float  # [Hz]; 0 = never
    max_steps_per_request: int
    command_timeout: float      # [s]; 0 = never
    safe_force: float           # [N]
    max_force: float            # [N]
    frame_id: str
    frame_prefix: str           # before each moving body's frame name (/tf child, IMU frame_id)
    state_rate: float           # [Hz]
    marker_rate: float          # [Hz]
    imu_rate: float             # [Hz]
    wait_for_subscribers: int
    wait_for_node: str
    publish_clock: bool
    singularity_warning: float

    @property
    def step_size(self) -> float:
        return self.step_ns / NS_PER_S


def _check_frame(node_name: str, name: str, value: str, *, may_be_empty: bool) -> None:
    """Refuse a frame name (or prefix) that tf2 would refuse to look up: its ``validateFrameId``
    throws for an empty frame id and for one starting with '/' (ROS 1's global names), so RViz,
    tf2 listeners and robot_localization could resolve none of the published frames."""
    if not value and not may_be_empty:
        raise ParameterValueError(f"{node_name}: parameter {name} must name a frame (tf2 refuses an empty frame id), "
                                  f"got ''")
    if value.startswith("/"):
        raise ParameterValueError(f"{node_name}: parameter {name} must not start with '/' (tf2 refuses such frame "
                                  f"ids: write {value.lstrip('/')!r}), got {value!r}")


def declare_sim_parameters(node: Node, scene: str) -> SimParameters:
    """Declare every parameter of ``tensegrity_sim`` on ``node`` but ``scene`` (declared and
    loaded by :func:`~tensegrity_ros.nodes.scene_param.declare_scene`, as for the IK node and the
    controller; its name is ``scene``); a bad value stops the node with a message naming
    the parameter."""
    def d(name: str, default: T, description: str, *, lo: float | None = None, hi: float | None = None) -> T:
        return declare(node, name, default, description, lo=lo, hi=hi, read_only=True)

    rate = d("publish_rate", 100.0, "free-running: ticks per wall second, each publishing the state [Hz]",
             lo=1.0, hi=1000.0)
    rtf = d("real_time_factor", 1.0, "free-running: simulated seconds per wall second; 0 = as fast as possible [s/s]",
            lo=0.0, hi=1000.0)
    step_size = d("step_size", 0.0,
                  "the simulation step, i.e. the control period [s], rounded to whole nanoseconds: /clock "
                  "advances by exactly this per step and a lockstep controller answers once per step "
                  "(the integrator takes its own adaptive steps inside it); 0 = 1 / publish_rate",
                  lo=0.0, hi=10.0)
    step_ns = round((step_size if step_size > 0 else 1.0 / rate) * NS_PER_S)
    if step_ns < 1000:
        raise ParameterValueError(f"{node.get_name()}: parameter step_size = {step_size!r} s is below 1 us")
    lockstep = d("lockstep", False,
                 "after publishing the state at t_k wait for a command stamped t_k, then integrate one step "
                 "under it (closed loops that reproduce exactly); false = free-running on the wall clock")
    lockstep_timeout = d("lockstep_timeout", 1.0,
                         "lockstep: wall time to wait for the command of a step before applying safe_force "
                         "for that step [s]", lo=1e-3, hi=3600.0)
    lockstep_rtf = d("lockstep_real_time_factor", 0.0,
                     "lockstep while playing: publish the next state no sooner than this many simulated "
                     "seconds per wall second allow (1 = real time, to watch or to pace a controller that "
                     "acts on wall time); every step still waits for its command, so a slow controller "
                     "slows the clock and never loses a step; 0 = as fast as the controller answers [s/s]",
                     lo=0.0, hi=1000.0)
    initial = d("initial_state", "playing", "state at start: playing, paused or stopped")
    if initial not in STATE_BY_NAME:
        raise ParameterValueError(f"{node.get_name()}: parameter initial_state must be one of "
                                  f"{', '.join(STATE_BY_NAME)}, got {initial!r}")
    paused_rate = d("paused_publish_rate", 1.0,
                    "paused or stopped: republish the (standing) state and clock at this rate [Hz]; 0 = never",
                    lo=0.0, hi=100.0)
    max_steps = d("max_steps_per_request", 1_000_000,
                  "largest StepSimulation / SimulateSteps request accepted [steps]", lo=1, hi=2**31 - 1)
    command_timeout = d("command_timeout", 0.5,
                        "free-running: after this many seconds of play without a valid command the forces "
                        "drop to safe_force (rest lengths are held) [s]; 0 = never", lo=0.0)
    safe_force = d("safe_force", 0.0, "actuator force applied after a command timeout or a lockstep timeout "
                   "(the class-2 mechanism) [N]")
    max_force = d("max_force", 1000.0, "commands with |f| above this are rejected [N]", lo=0.0)
    if abs(safe_force) > max_force:
        raise ParameterValueError(f"{node.get_name()}: parameter safe_force must be in [-max_force, max_force] = "
                                  f"[{-max_force:g}, {max_force:g}] N, got {safe_force:g} N")
    frame_id = d("frame_id", "world", "frame of the published positions")
    frame_prefix = d("frame_prefix", "",
                     "put before each moving body's frame name (the /tf child frames and the IMUs' frame_id), "
                     "as robot_state_publisher's frame_prefix: 'robot1/' keeps two robots' frames apart on "
                     "the one /tf; '' = the bodies' names")
    _check_frame(node.get_name(), "frame_id", frame_id, may_be_empty=False)
    _check_frame(node.get_name(), "frame_prefix", frame_prefix, may_be_empty=True)
    state_rate = d("state_rate", 100.0,
                   "publish rate of mechanism_state (class-2), cable_states (general structures, robots) and "
                   "contacts (robots) [Hz], counted in publications of joint_states at publish_rate; a divisor "
                   "of publish_rate is exact; above publish_rate it is capped at publish_rate (warned at start)",
                   lo=0.0, hi=1000.0)
    marker_rate = d("marker_rate", 30.0, "publish rate of the markers [Hz], counted (and capped) like state_rate",
                    lo=0.0, hi=1000.0)
    imu_rate = d("imu_rate", 100.0, "robots: publish rate of each imu/<body> topic [Hz], counted (and capped) like state_rate",
                 lo=0.0, hi=1000.0)
    wait = d("wait_for_subscribers", 0,
             "do not start the clock until every output topic has this many subscribers "
             "(e.g. 1 for a recorder that must see the run from t = 0) [subscribers]", lo=0, hi=1000)
    wait_node = d("wait_for_node", "",
                  "do not start the clock until the node of this name (in the simulator's namespace) "
                  "subscribes to every output topic, matched (`tensegrity up --record`: its recorder); "
                  "'' = no such wait")
    clock = d("publish_clock", True, "publish /clock from the simulation time")
    singular = d("singularity_warning", 0.05,
                 "warn (throttled) when lambda1/L or lambda2/L falls below this: the mass matrix grows like "
                 "1/lambda^2 and the simulation stops at 1e-3; 0 = never [fraction of L]", lo=0.0, hi=1.0)
    return SimParameters(scene, rate, rtf, step_ns, bool(lockstep), lockstep_timeout, lockstep_rtf,
                         STATE_BY_NAME[initial],
                         paused_rate, int(max_steps), command_timeout, safe_force, max_force, frame_id, frame_prefix,
                         state_rate,
                         marker_rate, imu_rate, int(wait), str(wait_node), bool(clock), singular)
