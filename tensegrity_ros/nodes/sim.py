"""``tensegrity_sim``: the simulated mechanism.

Subscribes ``actuator_forces`` (tensegrity_msgs/ActuatorForces; positive = tensile, pulls
the actuator's nodes together). Publishes, stamped with simulation time:

- ``joint_states`` (sensor_msgs/JointState): joints ``rho1``, ``rho2`` [m] and ``beta``
  [rad]; position, velocity, and effort = the applied actuator force [N] (0 for beta);
- ``end_effector`` (geometry_msgs/PointStamped): node D [m];
- ``mechanism_state`` (tensegrity_msgs/MechanismState): nodes, member lengths and
  forces, energies; at ``state_rate``;
- ``markers`` (visualization_msgs/MarkerArray): members coloured by force (red tension,
  blue compression), nodes as spheres; at ``marker_rate``;
- ``/clock`` (rosgraph_msgs/Clock): simulation time, so other nodes can use_sim_time.

Service ``reset`` (std_srvs/Trigger): back to the scene's initial state (and out of a
stopped simulation); the clock keeps running forward, so stamps stay monotonic.

The node runs on wall (steady) time and owns the simulation clock: each tick advances the
core simulator to ``real_time_factor`` x elapsed wall time (0 = as fast as possible, one
publish period of simulated time per tick). Bad commands (wrong lengths, unknown names,
NaN/inf, over ``max_force``) are rejected with a throttled warning naming the problem;
publishing never stops and NaN is never integrated. After ``command_timeout`` seconds
without a valid command the forces drop to ``safe_force``. When ``lambda1/L`` or
``lambda2/L`` falls below ``singularity_warning`` a throttled warning says which set is
near and how near, before the simulation has to stop there.
"""

from __future__ import annotations

import math
import sys
import threading
import time

from tensegrity_ros.nodes.common import declare, rclpy, spin_node
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import Point, PointStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Header
from std_srvs.srv import Trigger
from tensegrity_msgs.msg import ActuatorForces, MechanismState
from visualization_msgs.msg import Marker, MarkerArray

from tensegrity_core.class2 import dynamics_singularity
from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import clip, excerpt
from tensegrity_core.sim import Simulator, load_scene
from tensegrity_core.sim.simulator import JointSample
from tensegrity_ros.actuator_commands import CommandError, parse_command
from tensegrity_ros.matching import wait_for_matches

JOINT_NAMES = ["rho1", "rho2", "beta"]
#: Catch-up limit: if ticks fall this far behind wall time, the simulation slips instead.
MAX_LAG = 0.25


def sim_time_msg(t: float) -> TimeMsg:
    sec = math.floor(t)
    return TimeMsg(sec=int(sec), nanosec=min(int(round((t - sec) * 1e9)), 999_999_999))


def force_color(t: float, scale: float) -> ColorRGBA:
    """Red for tension, blue for compression, grey near zero; saturates at ``scale`` [N]."""
    a = max(-1.0, min(1.0, t / scale)) if scale > 0 else 0.0
    if a >= 0:
        return ColorRGBA(r=0.6 + 0.4 * a, g=0.6 - 0.5 * a, b=0.6 - 0.5 * a, a=1.0)
    return ColorRGBA(r=0.6 + 0.5 * a, g=0.6 + 0.5 * a, b=0.6 - 0.4 * a, a=1.0)


class SimNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("tensegrity_sim", **kwargs)
        scene_name = declare(self, "scene", "class2_at_rest",
                             "scene file or shipped scene name (tensegrity scenes lists them)", read_only=True)
        self.rate = declare(self, "publish_rate", 100.0, "publish rate of the state topics [Hz]", lo=1.0, hi=1000.0,
                            read_only=True)
        self.rtf = declare(self, "real_time_factor", 1.0,
                           "simulated seconds per wall second; 0 = as fast as possible", lo=0.0, hi=1000.0,
                           read_only=True)
        self.command_timeout = declare(self, "command_timeout", 0.5,
                                       "after this many seconds without a valid command the forces drop "
                                       "to safe_force [s]; 0 = never", lo=0.0, read_only=True)
        self.safe_force = declare(self, "safe_force", 0.0, "force applied after a command timeout [N]", read_only=True)
        self.max_force = declare(self, "max_force", 1000.0, "commands with |f| above this are rejected [N]", lo=0.0, read_only=True)
        self.frame_id = declare(self, "frame_id", "world", "frame of the published positions", read_only=True)
        self.state_rate = declare(self, "state_rate", 100.0,
                                  "publish rate of mechanism_state [Hz] (member forces, energies); a divisor of publish_rate is exact",
                                  lo=0.0, hi=1000.0, read_only=True)
        self.marker_rate = declare(self, "marker_rate", 30.0, "publish rate of the markers [Hz]", lo=0.0, hi=1000.0, read_only=True)
        self._state_every = max(1, round(self.rate / self.state_rate)) if self.state_rate > 0 else 0
        self._marker_every = max(1, round(self.rate / self.marker_rate)) if self.marker_rate > 0 else 0
        self.wait_for_subscribers = declare(
            self, "wait_for_subscribers", 0,
            "do not start the clock until every output topic has this many subscribers "
            "(e.g. 1 for a recorder that must see the run from t = 0)", lo=0, hi=1000, read_only=True)
        self.publish_clock = declare(self, "publish_clock", True, "publish /clock from the simulation time", read_only=True)
        self.singularity_warning = declare(
            self, "singularity_warning", 0.05,
            "warn (throttled) when lambda1/L or lambda2/L falls below this: the mass matrix grows like "
            "1/lambda^2 and the simulation stops at 1e-3; 0 = never", lo=0.0, hi=1.0, read_only=True)

        try:
            self.scene = load_scene(scene_name)
            self.sim = Simulator(self.scene)
        except TensegrityError as err:
            raise SystemExit(clip(f"tensegrity_sim: cannot load scene {excerpt(scene_name)}: {err}")) from None
        if self.sim.kind != "class2":
            raise SystemExit(f"tensegrity_sim: scene {excerpt(scene_name)} models a general structure; this node "
                             "drives the class-2 mechanism (use `tensegrity simulate` for general scenes)")

        qos = QoSProfile(depth=100)
        self.pub_joints = self.create_publisher(JointState, "joint_states", qos)
        self.pub_ee = self.create_publisher(PointStamped, "end_effector", qos)
        self.pub_state = self.create_publisher(MechanismState, "mechanism_state", qos)
        self.pub_markers = self.create_publisher(MarkerArray, "markers", 10)
        self.pub_clock = self.create_publisher(ClockMsg, "/clock", qos)
        # Latest command wins: a history of one means a burst or flood of commands can never
        # build a backlog that the simulation would apply late.
        self.create_subscription(ActuatorForces, "actuator_forces", self.on_command, 1)
        self.create_service(Trigger, "reset", self.on_reset)

        self.rejected = 0
        self.published = dict.fromkeys(("joint_states", "end_effector", "mechanism_state", "markers", "/clock"), 0)
        self._offset = 0.0               # published time = offset + core simulator time
        self._start(time.monotonic())
        self._lock = threading.Lock()        # the loop thread vs. reset and shutdown
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="tensegrity_sim_loop", daemon=True)
        self._thread.start()
        self.get_logger().info(
            f"scene {excerpt(scene_name)}: publishing at {self.rate:g} Hz, real-time factor "
            f"{self.rtf:g}{' (as fast as possible)' if self.rtf == 0 else ''}")

    def _start(self, now: float) -> None:
        """(Re)start the simulation clock bookkeeping for the current ``self.sim``."""
        # Until the first command the actuators hold what the scene starts with (for the
        # default scene: the forces that keep the mechanism at rest).
        self.command = [float(f) for f in self.sim.command]
        self.fault: str | None = None
        self._last_valid = None          # wall time of the last valid command
        self._timed_out = False
        self._wall0 = now
        self._sim0 = self.sim.t
        self._ticks = 0

    def on_reset(self, req: Trigger.Request, res: Trigger.Response) -> Trigger.Response:
        with self._lock:
            self._offset += self.sim.t
            self.sim = Simulator(self.scene)
            self._start(time.monotonic())
        res.success, res.message = True, f"reset to the initial state of scene {excerpt(self.scene.name)}"
        self.get_logger().info(res.message)
        return res

    def _loop(self) -> None:
        """The simulation loop, in its own thread: one tick per publish period of wall
        (steady) time, or back to back in as-fast-as-possible mode. A thread with its own
        deadline keeps 1 kHz where an executor timer's per-callback overhead does not."""
        period = 1.0 / self.rate
        if self.wait_for_subscribers > 0:
            publishers = (self.pub_joints, self.pub_ee, self.pub_state, self.pub_markers, self.pub_clock)
            self.get_logger().info(f"waiting for {self.wait_for_subscribers} subscriber(s) on every output topic")
            wait_for_matches(publishers, self.wait_for_subscribers,
                             should_stop=self._stop.is_set, poll=self._stop.wait)
            with self._lock:
                self._start(time.monotonic())
        deadline = time.monotonic()
        while not self._stop.is_set():
            with self._lock:
                try:
                    self.tick()
                except Exception as err:  # a failing tick must never kill publishing silently
                    if not rclpy.ok(context=self.context):
                        return                  # shutting down: publishers are gone
                    self.get_logger().error(f"tick failed: {type(err).__name__}: {err}",
                                            throttle_duration_sec=1.0)
            if self.rtf == 0:
                continue
            deadline += period
            delay = deadline - time.monotonic()
            if delay > 0:
                self._stop.wait(delay)
            elif delay < -MAX_LAG:
                deadline = time.monotonic()     # fell far behind: resynchronise, do not burst

    # -- commands ------------------------------------------------------------------------
    def on_command(self, msg: ActuatorForces) -> None:
        try:
            update = parse_command(list(msg.name), list(msg.force), max_abs_force=self.max_force)
        except CommandError as err:
            self.rejected += 1
            self.get_logger().warning(clip(f"rejected actuator command: {err} ({self.rejected} rejected so far)"),
                                      throttle_duration_sec=1.0)
            return
        self.command = update.apply(self.command)
        self._last_valid = time.monotonic()
        if self._timed_out:
            self._timed_out = False
            self.get_logger().info("commands resumed")

    def _effective_command(self, now: float) -> list[float]:
        if (self.command_timeout > 0 and self._last_valid is not None
                and now - self._last_valid > self.command_timeout):
            if not self._timed_out:
                self._timed_out = True
                self.get_logger().warning(
                    f"no valid command for {self.command_timeout:g} s: forces drop to {self.safe_force:g} N")
            return [self.safe_force] * len(self.command)
        return self.command

    # -- simulation tick -----------------------------------------------------------------
    def tick(self) -> None:
        now = time.monotonic()
        if self.fault is None:
            if self.rtf == 0:
                target = self.sim.t + 1.0 / self.rate
            else:
                target = self._sim0 + (now - self._wall0) * self.rtf
                if target - self.sim.t > MAX_LAG * self.rtf:   # fell behind: slip, do not burst
                    self._sim0, self._wall0 = self.sim.t + 1.0 / self.rate, now
                    target = self._sim0
            try:
                self.sim.set_command(self._effective_command(now))
                self.sim.advance(target)
            except TensegrityError as err:
                self.fault = str(err)
                self.get_logger().error(f"simulation stopped, state held: {err}")
        js = self.publish()
        self._warn_near_singular(js.q)

    def _warn_near_singular(self, q) -> None:
        name, distance = dynamics_singularity(float(q[0]), float(q[1]), self.sim.scene.model.params)
        if distance < self.singularity_warning:
            self.get_logger().warning(
                f"state near the singular set {name}: {name}/L = {distance:.3g} (rho1 = {q[0]:.4g} m, "
                f"rho2 = {q[1]:.4g} m); accelerations lose accuracy like 1/{name}^2 and the simulation "
                "stops at 1e-3", throttle_duration_sec=2.0)

    def publish(self) -> JointSample:
        """Joint states, end-effector and clock every tick; the full state and the markers
        (member forces: the expensive part of an observation) at their own rates. Returns
        the joint sample published."""
        js = self.sim.joint_sample()
        t = self._offset + js.t
        stamp = sim_time_msg(t)
        header = Header(stamp=stamp, frame_id=self.frame_id)
        if self.publish_clock:
            self.pub_clock.publish(ClockMsg(clock=stamp))
            self.published["/clock"] += 1
        msg = JointState(header=header, name=JOINT_NAMES)
        msg.position = [float(v) for v in js.q]
        msg.velocity = [float(v) for v in js.qdot]
        msg.effort = [float(js.applied_forces[0]), float(js.applied_forces[1]), 0.0]
        self.pub_joints.publish(msg)
        ee = js.end_effector
        self.pub_ee.publish(PointStamped(header=header, point=Point(x=float(ee[0]), y=float(ee[1]), z=float(ee[2]))))
        self.published["joint_states"] += 1
        self.published["end_effector"] += 1
        # the slower topics: every n-th tick (all rates are per wall-clock second)
        want_state = self._state_every > 0 and self._ticks % self._state_every == 0
        want_markers = self._marker_every > 0 and self._ticks % self._marker_every == 0
        self._ticks += 1
        if want_state or want_markers:
            obs = self.sim.observe()
            if want_state:
                self.pub_state.publish(self._state_msg(header, obs))
                self.published["mechanism_state"] += 1
            if want_markers:
                self.pub_markers.publish(self._markers(header, obs))
                self.published["markers"] += 1
        return js

    def destroy_node(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)
        counts = ", ".join(f"{k} {v}" for k, v in self.published.items())
        # the context may already be shut down (Ctrl-C): log without /rosout
        rclpy.logging.get_logger(f"{self.get_name()}_summary").info(f"published: {counts}; rejected commands: {self.rejected}")
        super().destroy_node()

    def _state_msg(self, header: Header, obs) -> MechanismState:
        m = MechanismState(header=header)
        m.q = [float(v) for v in obs.q]
        m.qdot = [float(v) for v in obs.qdot]
        m.actuator_force = [float(v) for v in obs.applied_forces]
        m.node_names = list(obs.node_names)
        m.nodes = [Point(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in obs.nodes]
        m.member_names = list(obs.member_names)
        m.member_lengths = [float(v) for v in obs.member_lengths]
        m.member_forces = [float(v) for v in obs.member_forces]
        m.end_effector = Point(x=float(obs.end_effector[0]), y=float(obs.end_effector[1]),
                               z=float(obs.end_effector[2]))
        m.potential_energy = float(obs.potential_energy)
        m.kinetic_energy = float(obs.kinetic_energy)
        m.folded = bool(obs.folded)
        return m

    def _markers(self, header: Header, obs) -> MarkerArray:
        scale = max(1e-9, max(abs(float(t)) for t in obs.member_forces))
        members = Marker(header=header, ns="members", id=0, type=Marker.LINE_LIST, action=Marker.ADD)
        members.scale.x = 0.02
        members.pose.orientation.w = 1.0
        for (i, j), t in zip(obs.member_nodes, obs.member_forces):
            for n in (i, j):
                p = obs.nodes[n]
                members.points.append(Point(x=float(p[0]), y=float(p[1]), z=float(p[2])))
                members.colors.append(force_color(float(t), scale))
        nodes = Marker(header=header, ns="nodes", id=1, type=Marker.SPHERE_LIST, action=Marker.ADD)
        nodes.scale.x = nodes.scale.y = nodes.scale.z = 0.05
        nodes.pose.orientation.w = 1.0
        nodes.color = ColorRGBA(r=0.9, g=0.9, b=0.9, a=1.0)
        nodes.points = [Point(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in obs.nodes]
        return MarkerArray(markers=[members, nodes])


def main(argv=None) -> int:
    return spin_node(SimNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
