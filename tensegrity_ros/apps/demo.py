"""The main job (``./run demo``): the suite end to end, over real DDS on loopback, in lockstep.

1. start the suite: ``tensegrity_sim`` (class-2 mechanism at rest, lockstep, paused,
   step = the control period), ``tensegrity_ik``, ``tensegrity_formfind`` and
   ``tensegrity_controller``, each its own process;
2. the end-effector motion, recorded to ``OUT/ik_motion``: ``solve_ik`` for each waypoint
   (seeded with the previous solution: one branch), then the controller's actions
   (:mod:`.demo_moves`): ``move_end_effector`` to each waypoint and a timed
   ``follow_actuator_trajectory``, the simulator stepped by this process while the
   controller answers every step; report each goal's settled error, settling time,
   overshoot and largest force; run it a second time and compare the joint states
   (identical); then the controller is stopped (the fold's law is this process's own);
3. the paper's fold scenario (Sect. 5.3), recorded to ``OUT/fold``: ``ResetSimulation``
   (rest at rho = (0.7, 0.7), clock at 0), then ``f_i = 10 rho_i t`` from the sampled
   lengths, held for each step; report the fold times from the simulator's ``events``;
   run it a second time and compare the joint states (identical); compare with the
   core's sampled-data run of the same loop (identical), and with the continuous-time
   ``paper_fold`` scene at 10, 100 and 1000 Hz (the core's sampled runs);
4. call ``find_form`` with the tensegrity-table example;
5. the 6-bar robot rolled in closed loop in a second simulator, recorded to ``OUT/six_bar_roll``
   and rerun identical (:mod:`.demo_robot`);
6. print a summary (tracking errors, fold times, the control-period table, bag contents).

Recording loses nothing (:mod:`.recording`): a phase starts only once the recorder has
received the first message of every topic the paused simulator publishes (the demo resets
the simulator until it has: a reset republishes the standing state) and has matched the
command publishers; after the phase the recorder is stopped only once its bag holds every
step's joint state, end effector, clock and command (what a stalled recorder missed comes
from the writers' history), and the demo says so per bag (exit code 1 if not).

The sample bags in ``bags/`` are the two recordings (``tensegrity demo -o OUT`` and copy
``OUT/fold`` and ``OUT/ik_motion``). Times are simulation times (integer nanoseconds of
the stamps).
"""

from __future__ import annotations

import shutil
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics
from tensegrity_core.class2.fold_law import FOLD_GAIN, paper_fold_forces
from tensegrity_core.sim.sampled import NS_PER_S, Controller, SampledRun, run_sampled, step_ns_of
from tensegrity_ros.apps import demo_moves, demo_robot
from tensegrity_ros.apps.demo_moves import WAYPOINT_OFFSETS, ControllerClient
from tensegrity_ros.apps.launch import Launcher, ProcessSpec
from tensegrity_ros.apps.recording import Recorder, RecorderNotReady
from tensegrity_ros.apps.sim_client import JointRecord, SimClient
from tensegrity_ros.bag.completeness import completeness_line
from tensegrity_ros.rclpy_utils.env import require_rclpy
from tensegrity_ros.rclpy_utils.futures import wait_done
from tensegrity_ros.rclpy_utils.matching import wait_for_matches, wait_for_service, wait_until_service_heard

__all__ = ["FOLD_GAIN", "WAYPOINT_OFFSETS", "run_demo"]

FOLD_TIME = 4.0     # s (simulated) of the paper's force law
CONTROL_PERIOD = 0.01   # s: the demo's control period (100 Hz)
TABLE_RATES = (10, 100, 1000)   # Hz: control rates of the table against the continuous run
SCENE = "class2_at_rest"        # the simulator's scene (commanded forces)
CONTINUOUS = "paper_fold"       # the same fold with the force law evaluated continuously
RECORDED_TOPICS = ("joint_states", "end_effector", "mechanism_state", "markers", "/clock", "actuator_forces",
                   "events")
#: What the paused simulator publishes when it is reset (markers with every third publication).
STATE_TOPICS = ("/joint_states", "/end_effector", "/mechanism_state", "/markers", "/clock")
#: Published once per lockstep step: a complete bag holds every step's stamp of each.
PER_STEP_TOPICS = ("/joint_states", "/end_effector", "/clock")
#: An IK goal: the end effector's target (x, y) [m] and the lengths (rho1, rho2) [m] solving it.
IKGoal = tuple[tuple[float, float], tuple[float, ...]]


def _say(text: str) -> None:
    print(f"[demo] {text}", flush=True)


def _ik_goals(client: DemoClient) -> list[IKGoal]:
    """``solve_ik`` for each waypoint, seeded with the previous solution (the first with rest)."""
    rest = forward_kinematics(0.7, 0.7, PAPER_PARAMS)
    current: list[float] = [0.7, 0.7]
    goals: list[IKGoal] = []
    for dx, dy in WAYPOINT_OFFSETS:
        target = (rest.x + dx, rest.y + dy)
        res = client.call_ik(target, current)
        if not res.success:
            raise RuntimeError(f"solve_ik({target[0]:.3f}, {target[1]:.3f}) failed: {res.message}")
        current = [res.solutions[0].rho1, res.solutions[0].rho2]
        goals.append((target, tuple(current)))
    return goals


def _moves(ctl: ControllerClient, step_ns: int, results: dict[str, Any], *, label: str) -> list[JointRecord]:
    """The controller phase (:func:`.demo_moves.run_moves`); its report printed the first time."""
    moves, traj, joints = demo_moves.run_moves(ctl, step_ns)
    results.setdefault("moves", {})[label] = (moves, traj)
    if label != "first":
        return joints
    for (target, rho), m in zip(results["ik_goals"], moves):
        status = "ok" if m.code == 0 else f"FAILED ({m.message})"
        _say(f"  move D to ({target[0]:.3f}, {target[1]:.3f}) m (IK rho = ({rho[0]:.4f}, {rho[1]:.4f}) m) in "
             f"{demo_moves.MOVE_TIME:g} s: {status}; settled error {m.settled_error * 1e3:.5f} mm, "
             f"settling {m.settling_time:.2f} s after the move, overshoot {m.overshoot * 1e3:.5f} mm, "
             f"max |f| {m.max_force:.2f} N; error {demo_moves.CHECK_AFTER:g} s after the move "
             f"{m.error_after * 1e3:.5f} mm")
    status = "ok" if traj.code == 0 else f"FAILED ({traj.message})"
    points = ", ".join(f"{t:g} s: ({r[0]:.2f}, {r[1]:.2f})" for t, r in demo_moves.TRAJECTORY)
    _say(f"  actuator trajectory rho = [{points}] m: {status}; largest length error while moving "
         f"{traj.max_path_error * 1e3:.3f} mm, final ({traj.final_error[0] * 1e3:+.4f}, "
         f"{traj.final_error[1] * 1e3:+.4f}) mm, D {traj.end_effector_error * 1e3:.4f} mm from the last point's, "
         f"max |f| {traj.max_force:.2f} N")
    return joints


def fold_times(events: Iterable[tuple[float, str, int]]) -> dict[str, float | None]:
    """First fold time [s] of each actuator, from ``(t, kind, index)`` events."""
    out: dict[int, float] = {}
    for t, kind, index in events:
        if kind == "fold" and index not in out:
            out[index] = float(t)
    return {f"rho{i + 1}": out.get(i) for i in (0, 1)}


def control_period_table(step_ns_list: Iterable[int], duration: float = FOLD_TIME, *,
                         runs: Mapping[int, SampledRun] | None = None) -> list[dict[str, Any]]:
    """The fold under the sampled law at each period against the continuous-time scene:
    first fold times, and the largest length difference at the sampling times before the
    first contact (after it the runs part: contacts touch and release at other times).
    ``runs``: the core's sampled runs of the fold already made, by step [ns] (the demo's own
    period's: computed again it would be the same run)."""
    import dataclasses

    from tensegrity_core.sim import load_scene, simulate

    # sampled at 1 kHz: every t_k of the table's rates is on its grid (no interpolation)
    cont = simulate(dataclasses.replace(load_scene(CONTINUOUS), output_rate=1000.0), duration=duration)
    cont_folds = fold_times(cont.events)
    rows = []
    for step_ns in step_ns_list:
        run = (runs or {}).get(step_ns)
        if run is None:
            run = run_sampled(SCENE, paper_fold_forces, step_ns=step_ns, duration=duration)
        first_contact = min(t for t in cont_folds.values() if t is not None)
        smooth = run.times < first_contact
        rho_c = np.column_stack([np.interp(run.times[smooth], cont.times, cont.q[:, i]) for i in (0, 1)])
        folds = fold_times(run.events)
        rows.append({"rate_hz": NS_PER_S / step_ns, "folds": folds, "continuous": cont_folds,
                     "fold_shift_s": {k: _shift(folds[k], cont_folds[k]) for k in folds},
                     "max_rho_error_m": float(np.max(np.abs(run.q[smooth, :2] - rho_c)))})
    return rows


def _shift(t: float | None, reference: float | None) -> float | None:
    """``t - reference`` [s]; None when either fold did not happen."""
    return t - reference if t is not None and reference is not None else None


def _fold(client: DemoClient, step_ns: int, results: dict[str, Any], *, label: str) -> list[JointRecord]:
    steps = round(FOLD_TIME * NS_PER_S) // step_ns
    client.sim.events.clear()
    joints = client.run(paper_fold_forces, steps)
    events = [(e.time, e.kind, int(e.index)) for e in client.sim.events]
    results.setdefault("fold_events", {})[label] = events
    return joints


def _joint_table(joints: Iterable[JointRecord]) -> dict[int, JointRecord]:
    """Joint states by stamp (a stamp published twice, e.g. at the start of a request, must
    carry the same values both times)."""
    out: dict[int, JointRecord] = {}
    for j in joints:
        if out.setdefault(j.stamp_ns, j) != j:
            raise RuntimeError(f"two different joint states stamped {j.stamp_ns} ns")
    return out


def _difference(first: dict[int, JointRecord], second: dict[int, JointRecord]) -> str:
    """How two joint tables (by stamp) differ: their sizes and the first stamp that differs."""
    stamps = sorted(set(first) | set(second))
    at = next(t for t in stamps if first.get(t) != second.get(t))
    return (f"DIFFERENT from the first ({len(first)} states there; first difference at t = "
            f"{at / NS_PER_S:.3f} s: {'missing in one run' if at not in first or at not in second else 'values'})")


class DemoClient:
    """The demo's node: the stepping client of the simulator, and clients of ``solve_ik``
    and ``find_form``."""

    step_ns: int        # the simulator's step [ns]

    def __init__(self, rclpy: ModuleType) -> None:
        from tensegrity_msgs.srv import FindForm, SolveIK

        self.sim = SimClient(rclpy, "tensegrity_demo")
        self.SolveIK, self.FindForm = SolveIK, FindForm
        node = self.sim.node
        self.ik = node.create_client(SolveIK, "solve_ik")
        self.ff = node.create_client(FindForm, "find_form")

    def _call(self, client: Any, request: Any, timeout: float = 120.0) -> Any:
        if not wait_for_service(client, timeout):
            raise RuntimeError(f"service {client.srv_name} not available")
        wait_until_service_heard(self.sim.node, client.srv_name, wait_done, timeout)   # else its answer can be lost
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _f: done.set())
        if not done.wait(timeout):
            raise RuntimeError(f"no answer from {client.srv_name} within {timeout:g} s")
        return future.result()

    def call_ik(self, target: tuple[float, float], seed: Sequence[float]) -> Any:
        return self._call(self.ik, self.SolveIK.Request(x=target[0], y=target[1], seed=list(seed)))

    def call_formfind(self, text: str) -> Any:
        return self._call(self.ff, self.FindForm.Request(structure=text))

    def run(self, law: Controller, steps: int) -> list[JointRecord]:
        """From rest with the clock at 0: ``steps`` lockstep steps under ``law``; the joint
        states received (one per step and the start)."""
        self.sim.set_law(None)
        self.sim.restart()
        self.sim.set_law(law, until_ns=steps * self.step_ns)
        self.sim.step(steps)
        self.sim.set_law(None)
        self.sim.wait_joint(steps * self.step_ns)          # the final state may still be in flight
        return self.sim.take_joints()

    def close(self) -> None:
        self.sim.close()


def run_demo(out: Path, *, control_period: float = CONTROL_PERIOD, record: bool = True,
             robot_faces: int = demo_robot.FACES) -> int:
    rclpy = require_rclpy()
    from tensegrity_core.general import example_path, structure_from_text
    from tensegrity_ros.bag.info import bag_info
    from tensegrity_ros.cli.cmd_formfind import answer_summary

    step_ns = step_ns_of(control_period)
    out.mkdir(parents=True, exist_ok=True)
    exe = [sys.executable, "-m", "tensegrity_ros.cli"]
    rate = min(1000.0, NS_PER_S / step_ns)
    sim_args = ["--ros-args", "-p", "lockstep:=true", "-p", "initial_state:=paused",
                "-p", f"step_size:={step_ns / NS_PER_S!r}", "-p", f"publish_rate:={rate!r}",
                "-p", "paused_publish_rate:=0.0", "-p", "lockstep_timeout:=10.0"]
    ctl_args = ["--ros-args", "-p", f"rate:={NS_PER_S / step_ns!r}"]
    for name, value in demo_moves.CONTROLLER_PARAMETERS.items():
        ctl_args += ["-p", f"{name}:={value!r}"]
    log = open(out / "suite.log", "w")
    launcher = Launcher([
        ProcessSpec("sim", exe + ["node", "sim", *sim_args]),
        ProcessSpec("ik", exe + ["node", "ik"]),
        ProcessSpec("formfind", exe + ["node", "formfind"]),
    ], out=log)
    controller = Launcher([ProcessSpec("controller", exe + ["node", "controller", *ctl_args])], out=log)
    _say(f"starting the suite (sim in lockstep, control period {step_ns / 1e6:g} ms; IK; form-finding; "
         f"controller); logs in {out / 'suite.log'}")
    launcher.start()
    controller.start()
    previous_term = signal.signal(signal.SIGTERM, signal.default_int_handler)  # SIGTERM -> clean stop
    rclpy.init()
    client = DemoClient(rclpy)
    client.step_ns = step_ns
    ctl = ControllerClient(client.sim)
    results: dict[str, Any] = {}
    bags: list[Path] = []
    rec: Recorder | None = None

    def recorded(name: str, title: str, phase: Callable[[], list[JointRecord]], *, controller_commands: bool
                 ) -> list[JointRecord]:
        """Run ``phase`` while ``OUT/name`` records the suite's topics (when recording); the
        phase starts once the recorder has received the first message of every topic the
        paused simulator publishes (resets make it publish) and, with ``controller_commands``,
        the controller's answer, else matched this process's command publisher; after it, the
        bag is checked to hold every step's messages."""
        nonlocal rec
        if record:
            folder = out / name
            if folder.exists():
                shutil.rmtree(folder)
            commands_before = client.sim.pub.get_subscription_count()
            rec = Recorder(folder, list(RECORDED_TOPICS))
            first = STATE_TOPICS + (("/actuator_forces",) if controller_commands else ())
            matched = {"/events": 1} if controller_commands else {"/events": 1, "/actuator_forces": 1}
            rec.wait_ready(first, client.sim.reset_all, matched=matched, every=0.2)
            if not controller_commands and not wait_for_matches([client.sim.pub], commands_before + 1, 60.0):
                raise RecorderNotReady("the demo's actuator_forces publisher did not match the recorder within 60 s")
            if controller_commands:
                ctl.connect()          # the controller answered the resets: the phase waits for a new answer
            bags.append(folder)
        _say(f"{title}" + (f" (recording {out / name})" if record else ""))
        value = phase()
        if rec is not None:
            stamps = sorted({j.stamp_ns for j in value})
            expected = {**dict.fromkeys(PER_STEP_TOPICS, stamps), "/actuator_forces": stamps[:-1]}
            rec.wait_complete(expected)
            code, rec = rec.stop(), None
            complete, line = completeness_line(folder, expected)
            results.setdefault("bags_complete", {})[name] = complete and code == 0
            _say(f"  bag {folder}: {line}" + ("" if code == 0 else f"; the recorder exited with code {code}"))
        return value

    try:
        client.sim.wait_for_services()
        ctl.wait_for_servers()
        ctl.connect()
        results["ik_goals"] = _ik_goals(client)
        moves_joints = recorded("ik_motion", "end-effector moves through the controller's actions "
                                "(move_end_effector to each waypoint, then follow_actuator_trajectory)",
                                lambda: _moves(ctl, step_ns, results, label="first"), controller_commands=True)
        _say("the moves again, not recorded: same lockstep run, compared stamp by stamp")
        moves_again = _moves(ctl, step_ns, results, label="second")
        first_moves, second_moves = _joint_table(moves_joints), _joint_table(moves_again)
        moves_identical = first_moves == second_moves
        _say(f"  second run: {len(second_moves)} joint states, "
             + ("identical to the first" if moves_identical else _difference(first_moves, second_moves)))
        if controller.stop() != 0:
            _say("  warning: the controller did not exit cleanly (see the log)")
        results["fold_joints"] = recorded(
            "fold", "the paper's fold scenario from rest, f_i = 10 rho_i t sampled and held",
            lambda: _fold(client, step_ns, results, label="first"), controller_commands=False)
        ft = fold_times(results["fold_events"]["first"])
        results["fold_times_s"] = ft
        for key, when in ft.items():
            _say(f"  {key} " + (f"folds at t = {when:.6f} s (event located by the simulator)" if when is not None
                                else "does not fold"))
        last = results["fold_joints"][-1].position
        _say(f"  after {FOLD_TIME:g} s: q = ({last[0]:.4f} m, {last[1]:.4f} m, {last[2]:.4f} rad)")

        _say("the fold again, not recorded: same lockstep run, compared stamp by stamp")
        again = _fold(client, step_ns, results, label="second")
        first_table, second_table = _joint_table(results["fold_joints"]), _joint_table(again)
        identical = first_table == second_table
        results["rerun_identical"] = identical
        _say(f"  second run: {len(second_table)} joint states, "
             + ("identical to the first (every position, velocity and effort bit for bit)" if identical
                else _difference(first_table, second_table)))
        _say("the same loop in the core (tensegrity_core.sim.sampled.run_sampled)")
        core = run_sampled(SCENE, paper_fold_forces, step_ns=step_ns, duration=FOLD_TIME)
        ros_q = np.array([first_table[round(t * NS_PER_S)].position for t in core.times])
        diff = float(np.max(np.abs(ros_q - core.q)))
        results["core_max_difference"] = diff
        _say(f"  {len(core.times)} samples; largest difference from the lockstep ROS run: {diff:.3g} "
             + ("(identical)" if diff == 0.0 else ""))

        _say(f"control period against the continuous-time {CONTINUOUS!r} scene (the core's sampled runs)")
        table = control_period_table([step_ns_of(1.0 / hz) for hz in TABLE_RATES], runs={step_ns: core})
        results["table"] = table
        cont = table[0]["continuous"]
        _say(f"  continuous: rho2 folds at {cont['rho2']:.6f} s, rho1 at {cont['rho1']:.6f} s")
        _say("  rate [Hz]  rho2 fold [s]  shift [s]   rho1 fold [s]  shift [s]   max |rho - rho_cont| [m] "
             "before the first fold")
        for row in table:
            f, d = row["folds"], row["fold_shift_s"]
            cells = [f"{f[k]:.6f}    {d[k]:+.2e}" if f[k] is not None else "  none      " for k in ("rho2", "rho1")]
            _say(f"  {row['rate_hz']:>9g}  {cells[0]}   {cells[1]}   {row['max_rho_error_m']:.3e}")

        _say("form-finding the tensegrity table through find_form")
        table_text = example_path("tensegrity_table").read_text()
        res = client.call_formfind(table_text)
        forces = np.array(res.member_forces)
        ratio = forces / forces[0] if res.success else []
        _say(f"  {'ok' if res.success else 'FAILED'}: {res.message}; "
             f"{answer_summary(res, structure_from_text(table_text))}; "
             f"forces / first = {np.round(ratio, 6).tolist()} (paper: [1, 1, 1, 3])")
        results["formfind_success"] = bool(res.success)

        robot_ok = True
        if robot_faces:
            robot_ok = demo_robot.run_robot(rclpy, out, step_ns=step_ns, record=record, results=results, bags=bags,
                                            say=_say, faces=robot_faces)

        _say("summary")
        moves, traj = results["moves"]["first"]
        moves_ok = all(m.code == 0 and m.error_after < demo_moves.GOAL_TOLERANCE for m in moves) and traj.code == 0
        _say(f"  controller: {len(moves)} moves, settled error max {max(m.settled_error for m in moves) * 1e3:.5f} mm "
             f"(goal tolerance {demo_moves.GOAL_TOLERANCE * 1e3:g} mm), error {demo_moves.CHECK_AFTER:g} s after each "
             f"move max {max(m.error_after for m in moves) * 1e3:.5f} mm; trajectory "
             f"{'succeeded' if traj.code == 0 else 'FAILED'}; rerun identical: {moves_identical}")
        _say("  fold (events): " + ", ".join(f"{k} at {v:.6f} s" if v is not None else f"{k} not folded"
                                            for k, v in ft.items())
             + f"; rerun identical: {identical}; core sampled run identical: {diff == 0.0}")
        if "robot" in results:
            _say(f"  6-bar ({robot_faces} faces asked, closed loop): {'; '.join(results['robot']['summary'])}; rerun "
                 f"identical: {results['robot']['identical']}")
        for folder in bags:
            info = bag_info(folder)
            counts = ", ".join(f"{t['name']} {t['count']}" for t in info["topics"])
            _say(f"  bag {folder}: {info['message_count']} messages ({counts}), "
                 f"{info['size_bytes'] / 1024:.0f} KiB")
        ok = (results.get("formfind_success", False) and moves_ok and moves_identical and identical
              and diff == 0.0 and all(results.get("bags_complete", {}).values()) and robot_ok)
        return 0 if ok else 1
    except KeyboardInterrupt:
        _say("interrupted")
        return 130
    except RuntimeError as err:       # a node or the recorder that did not answer or did not come up
        _say(f"failed: {err} (logs in {out / 'suite.log'})")
        return 1
    finally:
        if rec is not None:
            rec.stop()
        ctl.close()
        client.close()
        rclpy.try_shutdown()
        controller.stop()
        launcher.stop()
        log.close()
        signal.signal(signal.SIGTERM, previous_term)
