"""The robot back end: a tensegrity robot's dynamics, integrated in fixed steps.

:class:`RobotDynamic` compiles a robot scene (``model: {kind: robot}``) into a frozen model:
the :class:`~.plan.RobotPlan` of the effects it lists, the motors' input laws, the names
and the initial state. A state's integrator is a :class:`~.stepping.FixedStepper`.

Observations (each over the samples): the general back ends' quantities -- ``q``, ``qdot``
(body centres and rotation vectors from the drawing, their rates with the bodies' angular
velocities), ``applied_forces`` (the motors' rest lengths [m]), ``nodes``, members (the rods,
then the cables: ``member_lengths`` [m], ``member_forces`` [N], tension positive; a rod's
force is the mean of the axial loads on its two caps, tension positive: negative at rest, in
compression),
``potential_energy`` (gravity, cables' strain, the floor's contact and friction springs)
and ``kinetic_energy`` [J], ``end_effector`` (a node) and ``contact_forces`` (the caps'
normal forces [N]) -- and the robot's own: ``centre_of_mass`` [m]; with the ``sensors``
effect the readings of the description's sensors (:data:`SENSOR_KEYS`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import fields
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.events import LoggedEvent
from tensegrity_core.general.rotation import exact_rotations
from tensegrity_core.robot.imu import imu_readings
from tensegrity_core.robot.layout import robot_layout
from tensegrity_core.robot.motor import MODES, REEL_SPEED, TENSION
from tensegrity_core.sim.commands import changed, check_command, compile_inputs
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.general.model import kinetic_energy
from tensegrity_core.sim.general.robot.loops import SLIPPING
from tensegrity_core.sim.general.robot.plan import build_plan
from tensegrity_core.sim.general.robot.setup import initial_vector, names_of, robot_effects, robot_model, state_names
from tensegrity_core.sim.general.robot.stepping import FixedStepper, RobotSample
from tensegrity_core.sim.general.robot.system import RobotEvaluation, RobotSystem, block_index, empty_evaluation
from tensegrity_core.sim.inputs import Commanded
from tensegrity_core.sim.model import (
    Frozen,
    Interface,
    JointValues,
    Model,
    Observed,
    ObservedArrays,
    State,
    Stats,
    check_owner,
)
from tensegrity_core.sim.scene import Scene
from tensegrity_core.sim.scene.robot_schema import COMMAND_WORDS, command_range, modes_of

FloatArray = NDArray[np.float64]
#: Sensor readings a robot scene with the ``sensors`` effect observes (each over the samples):
#: lengths [m] and tensions [N] of the cables that report them; per IMU the orientation
#: quaternion (x, y, z, w), angular velocity [rad/s] and specific force [m/s^2] in its body's
#: frame; per cap whether it touches the floor, whether it slips, and its friction force [N].
SENSOR_KEYS = ("cable_lengths", "cable_tensions", "imu_orientation", "imu_angular_velocity", "imu_specific_force",
               "cap_contact", "cap_slipping", "friction_forces")


def cable_energy(stretch: FloatArray, k: FloatArray, t_max: FloatArray) -> FloatArray:
    """Stored energy [J] (B,) of cables with stretches ``l - l0`` (B, c) [m], stiffnesses
    ``k`` [N/m] and tension limits ``t_max`` [N] (inf: none): the potential of the elastic
    part of the cable's force ``min(k s, T_max)`` for ``s > 0`` (0 while slack),
    ``k s^2 / 2`` up to ``s = T_max / k`` and ``T_max (s - T_max / (2 k))`` beyond (where the
    spool pays out at the step's end, which only lowers it)."""
    s = np.maximum(stretch, 0.0)
    knee = np.minimum(s, t_max / k)
    out: FloatArray = np.sum(0.5 * k * knee * knee + np.where(s > knee, np.where(np.isfinite(t_max), t_max, 0.0) * (s - knee), 0.0), axis=1)
    return out


#: The fields of a :class:`RobotEvaluation` an evaluation fills (all but their ``block``).
_EVALUATED = tuple(f.name for f in fields(RobotEvaluation) if f.name != "block")


class RobotDynamic(Frozen, Model[FixedStepper, RobotSample]):
    """Back end ``robot/dynamic`` (implements :class:`~tensegrity_core.sim.model.Model`, and
    ``state_from``, ``equations`` as the dynamic back ends do)."""

    kind = "robot"
    quasi_static = False
    method = "RK4"

    def __init__(self, scene: Scene):
        self.scene = scene
        model = robot_model(scene)
        self.robot = robot = model.robot
        self.plan = build_plan(robot, robot_effects(scene))
        motors = scene.effects.get("motors")
        self.modes = modes_of(robot, motors)
        self.command_ranges = tuple(command_range(robot, j, int(m), motors) for j, m in enumerate(self.modes))
        self.laws, self.actuator_names, self.initial_commands = compile_inputs(scene.inputs, self._holding())
        self.names = names_of(robot, self.plan)
        mode_names = {v: k for k, v in MODES.items()}
        self.interface = Interface("rest_length", tuple(self.actuator_names),
                                   tuple(isinstance(law, Commanded) for law in self.laws),
                                   # the motors' closed command ranges as the open intervals the
                                   # interface states: one float further out on each side
                                   tuple((math.nextafter(lo, -math.inf), math.nextafter(hi, math.inf))
                                         for lo, hi in self.command_ranges),
                                   tuple(len(robot.rods) + int(c) for c in self.plan.motor_cable),
                                   tuple(mode_names[int(m)] for m in self.modes))
        # the commands' ranges as arrays, unbounded for inputs with a law (``_free``: their
        # values are ignored, but must be finite)
        self._free = np.array([not isinstance(law, Commanded) for law in self.laws], dtype=bool)
        self._lo = np.where(self._free, -np.inf, [r[0] for r in self.command_ranges])
        self._hi = np.where(self._free, np.inf, [r[1] for r in self.command_ranges])
        self._free_list: list[bool] = self._free.tolist()
        self._all_commanded = not self._free.any()
        self.state_names = state_names(robot, self.plan)
        self.step = scene.integrator.max_step
        self.y0 = initial_vector(robot, self.plan, scene.initial.lift)
        nb = len(self.plan.body_dof)
        self.system = RobotSystem(self.plan, laws=self.laws, commands=self.initial_commands, modes=self.modes,
                                  R_ref=np.broadcast_to(np.eye(3), (nb, 3, 3)))
        self.layout = robot_layout(robot)
        self.end_effector = robot_model(scene).end_effector
        self.node_mass = robot.lumped_masses()
        self.sensors = "sensors" in scene.effects
        self.gravity = np.asarray(scene.effects["gravity"].vector if "gravity" in scene.effects else np.zeros(3),
                                  dtype=float)
        # the IMUs' body slots (rods first, then the description's bodies)
        slot_of = {k: s for s, k in enumerate(self.layout.moving_bodies)}
        imu = list(robot.sensors.imu_rods) + [len(robot.rods) + b for b in robot.sensors.imu_bodies]
        self.imu_slots = np.array([slot_of[k] for k in imu if k in slot_of], dtype=int)
        motor = self.plan.motor_cable
        #: Where :meth:`joint_sample`'s values lie in an evaluation's block: the motor cables'
        #: rest lengths, lengths, rates, tensions, then the end effector's coordinates.
        self._joint_index = block_index(self.plan, [("rest_lengths", motor), ("lengths", motor), ("rates", motor),
                                                    ("tensions", motor),
                                                    ("positions", 3 * self.end_effector + np.arange(3))])

    def _holding(self) -> FloatArray:
        """(a,) the command that holds each motor as drawn: its drawn rest length [m], reel
        speed 0 [m/s], or the drawn tension [N] (``k (l - l0)^+`` at the drawn length)."""
        plan = self.plan
        i = plan.motor_cable
        drawn = plan.cable_l0[i]
        ends = self.robot.nodes[self.robot.cables.ends[i]]
        tension = plan.cable_k[i] * np.maximum(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1) - drawn, 0.0)
        out: FloatArray = np.where(self.modes == REEL_SPEED, 0.0, np.where(self.modes == TENSION, tension, drawn))
        return out

    # -- states ---------------------------------------------------------------------------------
    def initial_state(self, *, t_end: float = math.inf) -> State[FixedStepper]:
        """At rest as drawn, raised by the scene's ``initial.lift``."""
        return self._state(self.y0, t_end)

    def state_from(self, y: ArrayLike, *, t_end: float = math.inf) -> State[FixedStepper]:
        """A state at ``t = 0`` from the state vector ``y`` (``state_names``, in the drawing's charts)."""
        y = np.array(y, dtype=float).ravel()
        if len(y) != self.plan.n_state or not np.all(np.isfinite(y)):
            raise SimulationError(f"a state of this model is {self.plan.n_state} finite numbers, got {len(y)}")
        return self._state(y, t_end)

    def _state(self, y: FloatArray, t_end: float) -> State[FixedStepper]:
        events: list[LoggedEvent] = []
        return State(self.initial_commands, events, FixedStepper(self.system, y, self.step, t_end=t_end, log=events), owner=self)

    def equations(self, state: State[FixedStepper]) -> RobotSystem:
        """The equations (charts, inputs) the integrator sees at ``state``."""
        check_owner(self, state)
        return state.work.system

    # -- running ------------------------------------------------------------------------------
    def set_command(self, state: State[FixedStepper], values: Iterable[float]) -> None:
        """New commands for the commanded motors, each in its motor's mode (rest length [m],
        reel speed [m/s], tension [N]) and within its range; they act from the next step."""
        check_owner(self, state)
        if self._repeated(state, values):
            return
        commands = self._accepted(values)
        if commands is None:
            commands = self._checked(values)
        if commands == state.commands or not changed(state.commands, commands):
            return
        state.commands = commands
        state.work.command(state.work.system.with_commands(commands))

    def _repeated(self, state: State[FixedStepper], values: Iterable[float]) -> bool:
        """Whether ``values`` (a list or tuple) repeats the last command given to a robot whose
        motors are all commanded: it passed the checks then and changes nothing now."""
        return (self._all_commanded and state.commands is not self.initial_commands
                and isinstance(values, (list, tuple)) and tuple(values) == state.commands)

    def _accepted(self, values: Iterable[float]) -> tuple[float, ...] | None:
        """The commands of a list, tuple or array ``values`` that passes every check of
        :meth:`_checked` (one vectorised test: the per-step path of a lockstep controller), or
        None for anything else (:meth:`_checked` then accepts it or says what is wrong)."""
        if not isinstance(values, (list, tuple, np.ndarray)):
            return None
        try:
            u = np.array(values, dtype=np.float64)
        except (TypeError, ValueError):
            return None
        if u.shape != self._lo.shape or not bool(np.all(np.isfinite(u) & (self._lo <= u) & (u <= self._hi))):
            return None
        vals: list[float] = u.tolist()
        if self._all_commanded:
            return tuple(vals)
        # ``math.nan`` itself for the inputs with a law, as in the commands before: an unchanged
        # command then compares equal as a tuple
        return tuple(math.nan if free else v for free, v in zip(self._free_list, vals))

    def _checked(self, values: Iterable[float]) -> tuple[float, ...]:
        """``values`` as the new commands (:func:`~tensegrity_core.sim.commands.check_command`),
        each commanded one within its motor's range; raises :class:`SimulationError`."""
        commands = check_command(values, self.laws, self.actuator_names)
        for name, j, v in zip(self.actuator_names, range(len(commands)), commands):
            lo, hi = self.command_ranges[j]
            if not math.isnan(v) and not lo <= v <= hi:
                what, unit = COMMAND_WORDS[int(self.modes[j])]
                raise SimulationError(f"commanded {what} of {name} must be within its motor's range "
                                      f"[{lo:g}, {hi:g}] {unit}, got {v!r}")
        return commands

    def advance(self, state: State[FixedStepper], t: float) -> None:
        check_owner(self, state)
        state.work.advance(t)

    def sample(self, state: State[FixedStepper]) -> RobotSample:
        st = state.work
        return st.t, st.y.copy(), st.system

    def record(self, state: State[FixedStepper], times: Sequence[float] | FloatArray,
               out: list[RobotSample]) -> None:
        check_owner(self, state)
        state.work.record(times, out)

    def observe(self, samples: Sequence[RobotSample]) -> ObservedArrays:
        """The observations of ``samples`` (module docstring): each run of samples taken under
        one system (charts and inputs) evaluated by that system, into its rows of one evaluation
        of them all, which the observations are then computed from as one batch (a run under a
        controller changes the system at every control instant: batches of one sample each cost
        ~15 times the evaluation)."""
        ts = np.array([t for t, _, _ in samples], dtype=float)
        Y = np.array([y for _, y, _ in samples], dtype=float).reshape(len(samples), self.plan.n_state)
        ev = empty_evaluation(self.plan, len(samples))
        i = 0
        while i < len(samples):
            system = samples[i][2]
            j = i + 1
            while j < len(samples) and samples[j][2] is system:
                j += 1
            part = system.evaluate(Y[i:j])
            for name in _EVALUATED:
                getattr(ev, name)[i:j] = getattr(part, name)
            i = j
        return cast(ObservedArrays, self._observe(ts, Y, ev))

    def _observe(self, ts: FloatArray, Y: FloatArray, ev: RobotEvaluation) -> dict[str, NDArray[Any]]:
        plan, robot = self.plan, self.robot
        B, n = len(ts), plan.n_dof
        q = Y[:, :n].copy()
        nb = len(plan.body_dof)
        orientation = np.zeros((B, nb, 4))
        if nb and B:
            rot = plan.body_dof[:, None] + 3 + np.arange(3)[None, :]
            rotations = exact_rotations(ev.rotations.reshape(-1, 3, 3))
            q[:, rot] = rotations.as_rotvec().reshape(B, nb, 3)
            orientation = rotations.as_quat().reshape(B, nb, 4)
        X = ev.positions
        ends = robot.rods.ends
        axis = X[:, ends[:, 1]] - X[:, ends[:, 0]]
        rod_length = np.sqrt(np.sum(axis * axis, axis=2))
        e = axis / np.where(rod_length > 0, rod_length, 1.0)[..., None]
        # the loads on the caps pulling them apart (-e at cap a, +e at cap b), averaged: tension positive
        rod_force = 0.5 * (np.sum(ev.forces[:, ends[:, 1]] * e, axis=2) - np.sum(ev.forces[:, ends[:, 0]] * e, axis=2))
        strain = cable_energy(ev.lengths - ev.rest_lengths, plan.cable_k, plan.cable_t_max)
        gravity = -np.einsum("bki,ki->b", X, plan.external)
        k, kt = plan.floor_params[0], plan.floor_params[4]
        contact = 0.5 * k * np.sum(np.maximum(ev.depth, 0.0) ** 2, axis=1)
        ncap = len(plan.cap_node)
        a0 = 2 * n + len(plan.motor_cable)
        s = Y[:, a0:a0 + 3 * ncap].reshape(B, ncap, 3)
        cstate = Y[:, a0 + 3 * ncap:a0 + 4 * ncap]
        s = s - np.sum(s * plan.floor_normal, axis=2)[..., None] * plan.floor_normal
        anchor_energy = 0.5 * kt * np.sum(np.where(cstate > 0, np.sum(s * s, axis=2), 0.0), axis=1)
        com = np.einsum("k,bki->bi", self.node_mass, X) / self.node_mass.sum()
        nr = len(robot.rods)
        centre = plan.body_dof[:, None] + np.arange(3)
        out_bodies = {"body_positions": Y[:, centre], "body_velocities": Y[:, n + centre],
                      "body_angular_velocities": Y[:, n + 3 + centre], "body_orientations": orientation}
        out: dict[str, NDArray[Any]] = {
            "t": ts, "state": Y, "q": q, "qdot": Y[:, n:2 * n].copy(),
            "applied_forces": ev.rest_lengths[:, plan.motor_cable], "nodes": X,
            "member_lengths": np.concatenate([rod_length, ev.lengths], axis=1),
            "member_forces": np.concatenate([rod_force, ev.tensions], axis=1),
            "potential_energy": gravity + strain + contact + anchor_energy,
            "kinetic_energy": kinetic_energy(Y[:, n:2 * n], ev.rotations, 1.0 / plan.free_inv_mass if len(
                plan.free_inv_mass) else np.zeros(0), plan.body_dof, plan.body_mass, plan.body_first_moment,
                plan.body_inertia),
            "end_effector": X[:, self.end_effector].copy(),
            "folded": np.zeros(B, dtype=bool), "contact_forces": ev.normal, "centre_of_mass": com,
            "member_rest_lengths": np.concatenate([rod_length, ev.rest_lengths], axis=1),
            "member_rates": np.concatenate([np.zeros((B, nr)), ev.rates], axis=1),
            "member_slack": np.concatenate([np.zeros((B, nr), dtype=bool), ev.lengths < ev.rest_lengths], axis=1),
            **out_bodies}
        if self.sensors:
            sens = robot.sensors
            slots = self.imu_slots
            d = plan.body_dof[slots]
            cols = d[:, None] + np.arange(3)
            quat, gyro, specific = imu_readings(
                ev.rotations[:, slots].reshape(-1, 3, 3), Y[:, n + 3 + cols].reshape(-1, 3),
                ev.derivative[:, n + cols].reshape(-1, 3), ev.derivative[:, n + 3 + cols].reshape(-1, 3),
                np.zeros((B * len(slots), 3)), self.gravity, quaternions=orientation[:, slots].reshape(-1, 4))
            out |= {"cable_lengths": ev.lengths[:, list(sens.cable_length)],
                    "cable_tensions": ev.tensions[:, list(sens.cable_tension)],
                    "imu_orientation": quat.reshape(B, len(slots), 4),
                    "imu_angular_velocity": gyro.reshape(B, len(slots), 3),
                    "imu_specific_force": specific.reshape(B, len(slots), 3),
                    "cap_contact": ev.depth > 0.0, "cap_slipping": cstate == SLIPPING, "friction_forces": ev.friction}
        return out

    def contact_forces_and_nodes(self, sample: RobotSample) -> tuple[FloatArray, FloatArray]:
        """The caps' normal forces [N] (ncap,) and the node positions [m] (n, 3) of ``sample``,
        from one evaluation of it: :meth:`observe`'s ``contact_forces`` and ``nodes`` alone, what
        a sampled controller reads at each control instant
        (:class:`~tensegrity_core.sim.control_loop.ControlLoop`), at ~1/15 of the cost."""
        _, y, system = sample
        ev = system.evaluate(np.array([y], dtype=float))
        return ev.normal[0].copy(), ev.positions[0].copy()

    def observe_now(self, state: State[FixedStepper]) -> Observed:
        check_owner(self, state)
        arrays: dict[str, Any] = dict(self.observe([self.sample(state)]))
        data = {k: v[0] for k, v in arrays.items()}
        for key in ("t", "potential_energy", "kinetic_energy"):
            data[key] = float(data[key])
        data["folded"] = bool(data["folded"])
        return cast(Observed, data)

    def joint_sample(self, state: State[FixedStepper], *, coordinates: bool = True) -> JointValues:
        """The observation's joint values and its motor cables' lengths, rates and tensions,
        from one evaluation of the state (a fraction of :meth:`observe_now`'s cost: no
        energies, rod forces or sensors); ``coordinates=False``: ``q`` and ``qdot`` empty (the
        rods' rotation vectors cost about as much as the evaluation)."""
        check_owner(self, state)
        st = state.work
        ev = st.evaluation()
        # the motor cables' rest lengths, lengths, rates and tensions and the end effector's
        # position, copied out of the evaluation in one gather; the fields are views of it
        values = ev.block.take(self._joint_index)
        a = len(self.plan.motor_cable)
        q, qdot = values[:0], values[:0]
        if coordinates:
            plan, n = self.plan, self.plan.n_dof
            q, qdot = st.y[:n].copy(), st.y[n:2 * n].copy()
            if len(plan.body_dof):
                q[plan.body_dof[:, None] + 3 + np.arange(3)] = exact_rotations(ev.rotations[0]).as_rotvec()
        return JointValues(t=float(st.t), q=q, qdot=qdot, applied_forces=values[:a], end_effector=values[4 * a:],
                           folded=False, actuated_lengths=values[a:2 * a], actuated_rates=values[2 * a:3 * a],
                           actuated_forces=values[3 * a:4 * a])

    def singular_distance(self, state: State[FixedStepper]) -> None:
        """A robot has no singular sets of its equations of motion."""
        return None

    def stats(self, state: State[FixedStepper]) -> Stats:
        st = state.work
        return Stats(method=self.method, steps=st.n_steps, nfev=st.nfev, restarts=0, events=0, step=self.step)
