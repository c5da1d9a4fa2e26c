"""Re-simulation of a bag (``tensegrity play BAG --resimulate``): its recorded commands fed
into a lockstep ``tensegrity_sim`` at their recorded steps, its recorded joint states
compared with the re-simulated ones.

The bag's commands (``actuator_forces`` of the class-2 mechanism, or ``cable_commands``
of a general structure or robot: rest lengths by cable name; ``--scene`` names the scene it
was recorded with, e.g. ``six_bar_rest``) and ``joint_states`` (found by type, any
namespace) are read; the step is the bag's joint-state spacing (or given). A simulator is started in a
namespace of its own (lockstep, paused, no ``/clock``, so a running suite is not
disturbed), reset to the scene's initial state with the clock at 0, and stepped once over
the whole recording while this process answers each step ``k`` with the command in force
at ``t_k = t_first + k h`` (``t_first``: the first recorded joint state, the scene's
initial state): the last recorded command stamped at or before ``t_k`` (what a lockstep
recording has exactly at ``t_k``; a free-running one has commands between steps, which
lands each on the next step). A recording whose stamps are not on one grid (free-running)
is re-simulated at 1 ms unless ``step_size`` is given. Recorded joint states on the grid
are compared with the re-simulated ones at the same stamps; the others with the
re-simulated states interpolated linearly to their stamps (counted apart).

For a lockstep recording from the scene's initial state the difference is zero; for a
free-running one it measures how far the wall clock moved the commands.
"""

from __future__ import annotations

import bisect
import os
import statistics
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np
from rclpy.serialization import deserialize_message

from tensegrity_ros.bag.errors import BagError, decoded
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.recorder import message_class
from tensegrity_ros.bag.scene import recorded_scene
from tensegrity_ros.nodes.actuator_commands import CommandError, ForceUpdate, parse_command
from tensegrity_ros.nodes.sim.cable_commands import InputUpdate, parse_cable_command
from tensegrity_ros.rclpy_utils.env import require_rclpy
from tensegrity_ros.rclpy_utils.messages import stamp_ns

if TYPE_CHECKING:
    from tensegrity_ros.apps.sim_client import JointRecord

JOINT_TYPE = "sensor_msgs/msg/JointState"
COMMAND_TYPE = "tensegrity_msgs/msg/ActuatorForces"
#: The commands of general structures and robots: rest lengths [m] of actuated cables by name.
CABLE_COMMAND_TYPE = "tensegrity_msgs/msg/CableCommand"
NS_PER_S = 1_000_000_000
#: Longest re-simulation accepted [steps] (a bag from outside is bounded like any input).
MAX_STEPS = 2_000_000
#: Step of a free-running recording's re-simulation [ns]: its commands land within 1 ms.
FREE_RUNNING_STEP_NS = 1_000_000


#: Units of the simulator's joints (its joint_states: rho1, rho2 [m], beta [rad]); the
#: velocities are these per second.
JOINT_UNITS = {"rho1": "m", "rho2": "m", "beta": "rad"}


@dataclass(frozen=True)
class Resimulation:
    """What a re-simulation found: ``steps`` of ``step_ns``; ``compared`` recorded joint states
    at stamps on the step grid and ``off_grid`` others (compared with interpolated states);
    ``joints`` the recorded joint names; per joint the largest absolute differences of
    positions and velocities (``position_differences``, ``velocity_differences``, in
    ``units``: m or rad, per second for velocities) and their largest values over the joints
    (``max_position_difference``, ``max_velocity_difference``: mixed units, for a zero test);
    ``commands`` fed; ``start_difference``: recorded minus re-simulated positions at the
    first stamp (non-zero: the bag did not start at the scene's initial state)."""

    steps: int
    step_ns: int
    compared: int
    off_grid: int
    joints: list[str]
    units: list[str]
    position_differences: list[float]
    velocity_differences: list[float]
    max_position_difference: float
    max_velocity_difference: float
    commands: int
    first_difference_ns: int | None
    start_difference: list[float]
    scene: str

    def summary(self) -> str:
        where = "" if self.first_difference_ns is None else \
            f"; first difference at t = {self.first_difference_ns / NS_PER_S:.9f} s"
        return (f"re-simulated {self.steps} steps of {self.step_ns / NS_PER_S:.9g} s in lockstep, fed "
                f"{self.commands} recorded commands; compared {self.compared} recorded joint states"
                + (f" ({self.off_grid} off the step grid, against interpolated states)" if self.off_grid else "")
                + f": largest difference in position {self._per_joint(self.position_differences, '')}, "
                  f"in velocity {self._per_joint(self.velocity_differences, '/s')}{where}")

    def _per_joint(self, values: list[float], per: str) -> str:
        """Each joint's value with its unit; with more than four joints the largest, named."""
        if len(values) > 4:
            k = max(range(len(values)), key=lambda i: abs(values[i]))
            unit = f" {self.units[k]}{per}" if self.units[k] else ""
            return f"{values[k]:.3g}{unit} ({self.joints[k]}, the largest of {len(values)} joints)"
        return ", ".join(f"{name} {v:.3g}{f' {unit}{per}' if unit else ''}"
                         for name, unit, v in zip(self.joints, self.units, values))

    def warning(self) -> str:
        """"" when the bag starts where the scene does, else a line saying that it does not."""
        if not any(self.start_difference):
            return ""
        return (f"warning: the bag's first joint state is not the initial state of the scene {self.scene!r}: "
                f"{self._per_joint([abs(v) for v in self.start_difference], '')} apart; the re-simulation "
                "starts from the scene's, so the runs differ from the start (--scene names the bag's scene)")


#: A recorded command: ``(stamp [ns], names, forces [N] or rest lengths [m])``.
RecordedCommand: TypeAlias = tuple[int, list[str], list[float]]
#: A recorded joint state: ``(stamp [ns], positions, velocities)``.
RecordedJoints: TypeAlias = tuple[int, tuple[float, ...], tuple[float, ...]]
#: A command's update of the held command vector (forces or rest lengths), and its parser.
Update: TypeAlias = ForceUpdate | InputUpdate
Parse: TypeAlias = Callable[[Sequence[str], Sequence[float]], Update]




def read_recording(bag: str | Path) -> tuple[list[RecordedCommand], list[RecordedJoints], list[str], str]:
    """``(commands [(stamp_ns, names, values)], joints [(stamp_ns, position, velocity)],
    joint names, command type)``, each sorted by stamp, from the bag's command topic
    (ActuatorForces: forces [N]; or CableCommand: rest lengths [m]) and JointState topic
    (the names of the first joint state)."""
    reader = BagReader(bag)
    topics = {t.name: t.type for t in reader.topics()}
    cmd_topics = [n for n, t in topics.items() if t in (COMMAND_TYPE, CABLE_COMMAND_TYPE)]
    joint_topics = [n for n, t in topics.items() if t == JOINT_TYPE]
    if len(joint_topics) != 1:
        raise BagError(f"{bag}: re-simulation needs exactly one {JOINT_TYPE} topic, found {len(joint_topics)}")
    if len(cmd_topics) > 1:
        raise BagError(f"{bag}: more than one command topic: {', '.join(cmd_topics)}")
    cmd_type = topics[cmd_topics[0]] if cmd_topics else COMMAND_TYPE
    cmd_cls, joint_cls = message_class(cmd_type), message_class(JOINT_TYPE)
    commands: list[RecordedCommand] = []
    joints: list[RecordedJoints] = []
    names: list[str] = []
    for m in reader.messages(cmd_topics + joint_topics):
        where = f"bag {bag}: the message of {m.topic} logged at {m.log_time_ns} ns"
        if m.type == cmd_type:
            c = decoded(lambda data: deserialize_message(data, cmd_cls), m.data, where)
            values = c.force if cmd_type == COMMAND_TYPE else c.rest_length
            commands.append((stamp_ns(c.header.stamp), list(c.name), list(values)))
        else:
            j = decoded(lambda data: deserialize_message(data, joint_cls), m.data, where)
            joints.append((stamp_ns(j.header.stamp), tuple(j.position), tuple(j.velocity)))
            names = names or list(j.name)
    if not joints:
        raise BagError(f"{bag}: no joint states to compare with")
    commands.sort(key=lambda c: c[0])
    joints.sort(key=lambda j: j[0])
    return commands, joints, names, cmd_type


def infer_step_ns(joints: Sequence[RecordedJoints]) -> int:
    """The most common positive spacing of the joint-state stamps [ns]."""
    stamps = sorted({j[0] for j in joints})
    gaps = [b - a for a, b in zip(stamps, stamps[1:]) if b > a]
    if not gaps:
        raise BagError("cannot infer the step from a single joint state (give --step-size)")
    return statistics.mode(gaps)


def command_schedule(commands: Sequence[RecordedCommand], steps: int, step_ns: int, initial: Sequence[float],
                     start_ns: int = 0, parse: Parse | None = None) -> tuple[list[tuple[float, ...]], int]:
    """The command vector in force at each step ``k < steps`` (last command stamped at or
    before ``start_ns + k step_ns``, names applied cumulatively from ``initial``), and how
    many commands were used. ``parse(names, values)`` gives a command's update (default:
    actuator forces, any size)."""
    if parse is None:
        def parse(names: Sequence[str], values: Sequence[float]) -> Update:
            return parse_command(names, values, max_abs_force=float("inf"))
    stamps = [c[0] for c in commands]
    held, applied, schedule = list(initial), 0, []
    for k in range(steps):
        n = bisect.bisect_right(stamps, start_ns + k * step_ns)
        while applied < n:
            _, names, forces = commands[applied]
            try:
                held = parse(names, forces).apply(held)
            except CommandError as err:
                raise BagError(f"recorded command {applied} cannot be applied: {err}") from None
            applied += 1
        schedule.append(tuple(held))
    return schedule, applied


def resimulate(bag: str | Path, *, scene: str | None = None, step_size: float | None = None,
               lockstep_timeout: float = 10.0) -> Resimulation:
    """Re-simulate ``bag`` (see the module note) on ``scene``: by default the shipped scene
    the bag's metadata names, else ``class2_at_rest`` (the simulator node's default); needs
    the ROS wheels."""
    from tensegrity_core.sim import Simulator, load_scene

    if scene is None:
        scene = recorded_scene(BagReader(bag), bag) or "class2_at_rest"
    commands, joints, names, cmd_type = read_recording(bag)
    start = joints[0][0]
    if step_size is not None:
        step_ns = round(step_size * NS_PER_S)
    else:
        step_ns = infer_step_ns(joints)
        if sum((j[0] - start) % step_ns == 0 for j in joints) < len(joints) / 2:
            step_ns = FREE_RUNNING_STEP_NS
    if step_ns < 1000:
        raise BagError(f"step {step_ns} ns is below 1 us")
    steps = -(-(joints[-1][0] - start) // step_ns)
    if steps > MAX_STEPS:
        raise BagError(f"{bag}: {steps} steps of {step_ns} ns to cover {(joints[-1][0] - start) / NS_PER_S:g} s "
                       f"of joint states: more than the limit {MAX_STEPS}")
    sim = Simulator(load_scene(scene))
    interface = sim.model.interface
    cables = cmd_type == CABLE_COMMAND_TYPE
    if cables != (interface.command == "rest_length"):
        raise BagError(f"{bag}: its commands are {'cable rest lengths' if cables else 'actuator forces'}, but scene "
                       f"{scene!r} takes {interface.command.replace('_', ' ')}s: give --scene the scene it was "
                       "recorded with")
    parse: Parse | None = None
    if cables:
        def parse_cables(names: Sequence[str], values: Sequence[float]) -> Update:
            return parse_cable_command(names, values, [], [], interface)
        parse = parse_cables
    schedule, used = command_schedule(commands, steps, step_ns, sim.command, start, parse)
    commanded = tuple(i for i, c in enumerate(interface.commanded) if c) if cables else None
    resim = _resimulated(schedule, steps, step_ns, scene, lockstep_timeout,
                         None if commanded is None else (commanded, tuple(interface.inputs[i] for i in commanded)))
    grid = np.array([start + k * step_ns for k in range(steps + 1)])
    q = np.array([resim[k * step_ns].position for k in range(steps + 1)])
    v = np.array([resim[k * step_ns].velocity for k in range(steps + 1)])
    compared = off_grid = 0
    width = q.shape[1]
    dq, dv = np.zeros(width), np.zeros(width)
    first = None
    for stamp, position, velocity in joints:
        k, rest = divmod(stamp - start, step_ns)
        if rest == 0:
            compared += 1
            got_q, got_v = q[k], v[k]
        else:
            off_grid += 1
            got_q = np.array([np.interp(stamp, grid, q[:, i]) for i in range(width)])
            got_v = np.array([np.interp(stamp, grid, v[:, i]) for i in range(width)])
        e_q = np.abs(np.asarray(position[:width], dtype=float) - got_q)
        e_v = np.abs(np.asarray(velocity[:width], dtype=float) - got_v)
        if (e_q.any() or e_v.any()) and first is None:
            first = stamp
        dq, dv = np.maximum(dq, e_q), np.maximum(dv, e_v)
    names = (names + [f"joint {i + 1}" for i in range(len(names), width)])[:width]
    start_difference = np.asarray(joints[0][1][:width], dtype=float) - q[0]
    units = ["m"] * len(names) if cables else [JOINT_UNITS.get(n, "") for n in names]
    return Resimulation(steps, step_ns, compared, off_grid, names, units,
                        dq.tolist(), dv.tolist(), float(dq.max(initial=0.0)), float(dv.max(initial=0.0)), used,
                        first, start_difference.tolist(), scene)


def _resimulated(schedule: Sequence[tuple[float, ...]], steps: int, step_ns: int, scene: str,
                 lockstep_timeout: float,
                 cables: tuple[tuple[int, ...], tuple[str, ...]] | None = None) -> dict[int, JointRecord]:
    """Joint states by stamp from a lockstep simulator stepped under ``schedule``; with
    ``cables`` = (input indices, names) of the commanded cables, as ``CableCommand``."""
    rclpy = require_rclpy()
    from tensegrity_ros.apps.launch import Launcher, ProcessSpec
    from tensegrity_ros.apps.sim_client import SimClient

    namespace = f"/tensegrity_resimulate_{os.getpid()}"
    argv = [sys.executable, "-m", "tensegrity_ros.cli", "node", "sim", "--ros-args", "-r", f"__ns:={namespace}",
            "-p", f"scene:={scene}", "-p", "lockstep:=true", "-p", "initial_state:=paused",
            "-p", f"step_size:={step_ns / NS_PER_S!r}", "-p", "publish_clock:=false",
            "-p", "paused_publish_rate:=0.0", "-p", "state_rate:=0.0", "-p", "marker_rate:=0.0",
            "-p", f"lockstep_timeout:={lockstep_timeout!r}", "-p", "max_steps_per_request:=2000000"]
    log = open(os.devnull, "w")
    launcher = Launcher([ProcessSpec("resim", argv)], out=log)
    launcher.start()
    rclpy.init()
    client = None
    try:
        client = SimClient(rclpy, "tensegrity_resimulate", namespace=namespace, record_events=False,
                           cables=None if cables is None else cables[1])
        client.wait_for_services()
        client.reset_all()
        def law(sample: Any) -> Sequence[float]:
            row = schedule[round(sample.t * NS_PER_S) // step_ns]
            return row if cables is None else [row[i] for i in cables[0]]
        client.set_law(law, until_ns=steps * step_ns)
        client.step(steps, timeout=max(600.0, steps * 0.05))
        client.wait_joint(steps * step_ns)
        client.set_law(None)
        out: dict[int, JointRecord] = {}
        for j in client.take_joints():
            out.setdefault(j.stamp_ns, j)
        return out
    finally:
        if client is not None:
            client.close()
        rclpy.try_shutdown()
        launcher.stop()
        log.close()


__all__ = ["Resimulation", "command_schedule", "infer_step_ns", "read_recording", "resimulate"]
