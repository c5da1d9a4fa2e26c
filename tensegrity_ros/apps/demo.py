"""The main job (``./run demo``): the suite end to end, over real DDS on loopback.

1. start the suite: ``tensegrity_sim`` (class-2 mechanism at rest, commanded forces),
   ``tensegrity_ik`` and ``tensegrity_formfind``, each its own process;
2. IK-driven motion, recorded to ``OUT/ik_motion``: for each waypoint of the end-effector,
   call ``solve_ik`` (seeded with the current lengths so the motion stays on one branch)
   and drive the actuators there through ``actuator_forces`` with
   :class:`~tensegrity_core.class2.control.ActuatorTracker` (holding forces + PD, with
   beta damped through the springs); report where D settles against the target;
3. the paper's fold scenario: reset the simulator to rest at rho = (0.7, 0.7), then,
   recorded to ``OUT/fold``, ``f_i = 10 rho_i t`` from the measured lengths (Sect. 5.3);
   report when each actuator reaches the fold limit;

The sample bags in ``bags/`` are these two recordings (``tensegrity demo -o OUT`` and
copy ``OUT/fold`` and ``OUT/ik_motion``).
4. call ``find_form`` with the tensegrity-table example;
5. print a summary (tracking errors, fold times, form-finding, bag contents).

Times in the control loop are simulation times (the stamps of ``joint_states``).
"""

from __future__ import annotations

import math
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics
from tensegrity_core.class2.control import ActuatorTracker
from tensegrity_ros.apps.launch import Launcher, ProcessSpec
from tensegrity_ros.rclpy_utils.env import require_rclpy

#: End-effector waypoints, offsets [m] from D at rho1 = rho2 = 0.7 (the scene's rest).
WAYPOINT_OFFSETS = ((0.08, 0.0), (0.08, 0.06), (-0.04, 0.06), (0.0, 0.0))
MOVE_TIME = 2.0     # s (simulated) per move, smoothstep in the actuator lengths
DWELL_TIME = 2.5    # s (simulated) at each waypoint before its error is measured
FOLD_TIME = 4.0     # s (simulated) of the paper's force law
FOLD_GAIN = 10.0    # N/(m s): f_i = FOLD_GAIN * rho_i * t (Sect. 5.3)
FOLD_LENGTH = 1e-6  # m: an actuator this short counts as folded (the limit holds it at 0
                    # only while the contact pushes; it may touch and leave between samples)


def _say(text: str) -> None:
    print(f"[demo] {text}", flush=True)


@dataclass
class Feedback:
    """Latest joint state (thread-safe enough: replaced as a whole tuple)."""

    sample: tuple | None = None        # (t, rho(2,), rho_dot(2,), beta, beta_dot)
    event: threading.Event = field(default_factory=threading.Event)


class DemoClient:
    """The demo's own node: feedback from ``joint_states``, commands on ``actuator_forces``,
    clients of ``solve_ik`` and ``find_form``. Its executor spins in a background thread;
    the control law runs in the ``joint_states`` callback."""

    def __init__(self, rclpy) -> None:
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import JointState
        from tensegrity_msgs.msg import ActuatorForces
        from std_srvs.srv import Trigger
        from tensegrity_msgs.srv import FindForm, SolveIK

        self.rclpy = rclpy
        self.node = rclpy.create_node("tensegrity_demo")
        self.ActuatorForces = ActuatorForces
        self.SolveIK, self.FindForm, self.Trigger = SolveIK, FindForm, Trigger
        self.pub = self.node.create_publisher(ActuatorForces, "actuator_forces", 10)
        self.node.create_subscription(JointState, "joint_states", self._on_joints, QoSProfile(depth=100))
        self.ik = self.node.create_client(SolveIK, "solve_ik")
        self.ff = self.node.create_client(FindForm, "find_form")
        self.reset = self.node.create_client(Trigger, "reset")
        self.feedback = Feedback()
        self.law = None                 # callable(t, rho, rho_dot, beta, beta_dot) -> (f1, f2)
        self._lock = threading.Lock()
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self.executor.spin, daemon=True)
        self._thread.start()

    def _on_joints(self, msg) -> None:
        t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        rho, rho_dot = np.array(msg.position[:2]), np.array(msg.velocity[:2])
        beta, beta_dot = float(msg.position[2]), float(msg.velocity[2])
        self.feedback.sample = (t, rho, rho_dot, beta, beta_dot)
        self.feedback.event.set()
        with self._lock:
            law = self.law
        if law is not None:
            f1, f2 = law(t, rho, rho_dot, beta, beta_dot)
            cmd = self.ActuatorForces(name=["f1", "f2"], force=[float(f1), float(f2)])
            cmd.header.stamp = msg.header.stamp
            self.pub.publish(cmd)

    def set_law(self, law) -> None:
        with self._lock:
            self.law = law

    def wait_sample(self, timeout: float = 30.0) -> tuple:
        self.feedback.event.clear()
        if not self.feedback.event.wait(timeout):
            raise RuntimeError(f"no joint_states within {timeout:g} s")
        return self.feedback.sample

    def run_until(self, t_end: float, timeout: float = 120.0) -> tuple:
        """Block until the simulation time reaches ``t_end``; return the last sample."""
        deadline = time.monotonic() + timeout
        while True:
            sample = self.wait_sample()
            if sample[0] >= t_end:
                return sample
            if time.monotonic() > deadline:
                raise RuntimeError(f"simulation time did not reach {t_end:g} s within {timeout:g} s")

    def call(self, client, request, timeout: float = 60.0):
        if not client.wait_for_service(timeout_sec=timeout):
            raise RuntimeError(f"service {client.srv_name} not available")
        future = client.call_async(request)
        deadline = time.monotonic() + timeout
        while not future.done():
            if time.monotonic() > deadline:
                raise RuntimeError(f"no answer from {client.srv_name} within {timeout:g} s")
            time.sleep(0.005)
        return future.result()

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


class Recorder:
    """``tensegrity record`` as a child process, stopped with SIGINT (finishes the bag)."""

    def __init__(self, folder: Path, ros_args: list[str]):
        self.folder = folder
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tensegrity_ros.cli", "record", "-o", str(folder), *ros_args],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self._lines: list[str] = []
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        for line in self.proc.stderr:
            self._lines.append(line.rstrip())

    def wait_subscribed(self, topics: int, timeout: float = 30.0) -> None:
        """Wait until the recorder reports ``topics`` subscriptions (or times out)."""
        deadline = time.monotonic() + timeout
        while sum(line.startswith("recording /") for line in self._lines) < topics:
            if self.proc.poll() is not None:
                raise RuntimeError("recorder exited: " + "\n".join(self._lines[-5:]))
            if time.monotonic() > deadline:
                return
            time.sleep(0.05)

    def stop(self) -> int:
        self.proc.send_signal(signal.SIGINT)
        return self.proc.wait(60)


def _ik_motion(client: DemoClient, tracker: ActuatorTracker, results: dict) -> None:
    rest = forward_kinematics(0.7, 0.7, tracker.params)
    t, rho, _, _, _ = client.wait_sample()
    current = rho.copy()
    errors = []
    for dx, dy in WAYPOINT_OFFSETS:
        target = (rest.x + dx, rest.y + dy)
        res = client.call(client.ik, client.SolveIK.Request(x=target[0], y=target[1], seed=list(current)))
        if not res.success:
            raise RuntimeError(f"solve_ik({target[0]:.3f}, {target[1]:.3f}) failed: {res.message}")
        goal = np.array([res.solutions[0].rho1, res.solutions[0].rho2])
        start, t0 = current.copy(), client.wait_sample()[0]

        def law(t, rho, rho_dot, beta, beta_dot, start=start, goal=goal, t0=t0):
            u = min(max((t - t0) / MOVE_TIME, 0.0), 1.0)
            ref = start + (goal - start) * (u * u * (3.0 - 2.0 * u))
            return tracker.forces(ref, rho, rho_dot, beta_dot)

        client.set_law(law)
        t, rho, _, beta, _ = client.run_until(t0 + MOVE_TIME + DWELL_TIME)
        L = tracker.params.L
        d = (rho[0] + L * math.cos(beta), L * math.sin(beta))
        err = math.hypot(d[0] - target[0], d[1] - target[1])
        errors.append(err)
        _say(f"  waypoint D = ({target[0]:.3f}, {target[1]:.3f}) m: IK rho = ({goal[0]:.4f}, {goal[1]:.4f}) m, "
             f"D settled at ({d[0]:.4f}, {d[1]:.4f}) m, error {1000 * err:.1f} mm")
        current = goal
    results["ik_errors_m"] = errors


def _reset(client: DemoClient) -> None:
    """Back to rest at rho = (0.7, 0.7): the simulator's reset service, then hold."""
    client.set_law(None)
    res = client.call(client.reset, client.Trigger.Request())
    if not res.success:
        raise RuntimeError(f"reset failed: {res.message}")
    client.wait_sample()


def _fold(client: DemoClient, results: dict) -> None:
    t0 = client.wait_sample()[0]
    folded_at: dict[int, float] = {}

    def law(t, rho, rho_dot, beta, beta_dot):
        for i in (0, 1):
            if i not in folded_at and rho[i] <= FOLD_LENGTH:
                folded_at[i] = t - t0
        tau = max(t - t0, 0.0)
        return FOLD_GAIN * rho[0] * tau, FOLD_GAIN * rho[1] * tau

    client.set_law(law)
    t, rho, _, beta, _ = client.run_until(t0 + FOLD_TIME)
    results["fold_times_s"] = {f"rho{i + 1}": folded_at.get(i) for i in (0, 1)}
    results["fold_final_q"] = (float(rho[0]), float(rho[1]), float(beta))
    for i in (0, 1):
        when = folded_at.get(i)
        _say(f"  rho{i + 1} " + (f"reached the fold limit at t = {when:.3f} s" if when is not None
                                  else f"did not fold (rho{i + 1} = {rho[i]:.4f} m)"))
    _say(f"  after {FOLD_TIME:g} s: q = ({rho[0]:.4f} m, {rho[1]:.4f} m, {beta:.4f} rad)")


def run_demo(out: Path, *, real_time_factor: float = 2.0, record: bool = True) -> int:
    rclpy = require_rclpy()
    from tensegrity_core.general import example_path
    from tensegrity_ros.bag.info import bag_info

    out.mkdir(parents=True, exist_ok=True)
    exe = [sys.executable, "-m", "tensegrity_ros.cli"]
    sim_args = ["--ros-args", "-p", f"real_time_factor:={real_time_factor}", "-p", "publish_rate:=200.0",
                "-p", "command_timeout:=1.0"]
    launcher = Launcher([
        ProcessSpec("sim", exe + ["node", "sim", *sim_args]),
        ProcessSpec("ik", exe + ["node", "ik"]),
        ProcessSpec("formfind", exe + ["node", "formfind"]),
    ], out=open(out / "suite.log", "w"))
    _say(f"starting the suite (sim at {real_time_factor:g}x real time, IK, form-finding); logs in {out / 'suite.log'}")
    launcher.start()
    previous_term = signal.signal(signal.SIGTERM, signal.default_int_handler)  # SIGTERM -> clean stop
    rclpy.init()
    client = DemoClient(rclpy)
    results: dict = {}
    bags: list[Path] = []
    rec = None
    try:
        client.wait_sample(timeout=60)
        tracker = ActuatorTracker(PAPER_PARAMS, kp=100.0, kd=20.0, kbeta=0.3)
        phases = (("ik_motion", None, lambda: _ik_motion(client, tracker, results),
                   "IK-driven motion through end-effector waypoints"),
                  ("fold", lambda: _reset(client), lambda: _fold(client, results),
                   "the paper's fold scenario from rest, f_i = 10 rho_i t"))
        for name, prepare, phase, title in phases:
            if prepare is not None:
                prepare()
            rec = None
            if record:
                folder = out / name
                if folder.exists():
                    import shutil
                    shutil.rmtree(folder)
                rec = Recorder(folder, [])
                rec.wait_subscribed(topics=5)
                bags.append(folder)
            _say(f"{title}" + (f" (recording {out / name})" if record else ""))
            phase()
            if rec is not None:
                rec.stop()
                rec = None
        client.set_law(None)

        _say("form-finding the tensegrity table through find_form")
        text = example_path("tensegrity_table").read_text()
        res = client.call(client.ff, client.FindForm.Request(structure=text))
        forces = np.array(res.member_forces)
        ratio = forces / forces[0] if res.success else []
        _say(f"  {'ok' if res.success else 'FAILED'}: {res.message}; {res.iterations} iterations, residual "
             f"{res.residual:.2g} N, min stiffness eigenvalue {res.min_stiffness_eigenvalue:.4g}; "
             f"forces / first = {np.round(ratio, 6).tolist()} (paper: [1, 1, 1, 3])")
        results["formfind_success"] = bool(res.success)

        _say("summary")
        errs = results.get("ik_errors_m", [])
        if errs:
            _say(f"  IK motion: {len(errs)} waypoints, settled error max {1000 * max(errs):.1f} mm")
        ft = results.get("fold_times_s", {})
        _say("  fold: " + ", ".join(f"{k} at {v:.3f} s" if v is not None else f"{k} not folded"
                                     for k, v in ft.items())
             + " (here the force law is sampled at the joint-state rate and acts one tick late; the core's "
               "continuous-time paper_fold scene has rho2 touch zero at 1.381 s and rho1 at 1.535 s)")
        for folder in bags:
            info = bag_info(folder)
            counts = ", ".join(f"{t['name']} {t['count']}" for t in info["topics"])
            _say(f"  bag {folder}: {info['message_count']} messages ({counts}), "
                 f"{info['size_bytes'] / 1024:.0f} KiB")
        ok = results.get("formfind_success", False) and len(errs) == len(WAYPOINT_OFFSETS)
        return 0 if ok else 1
    except KeyboardInterrupt:
        _say("interrupted")
        return 130
    finally:
        client.set_law(None)
        if rec is not None:
            rec.stop()
        client.close()
        rclpy.try_shutdown()
        launcher.stop()
        signal.signal(signal.SIGTERM, previous_term)
