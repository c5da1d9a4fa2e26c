"""A robot scene's own parts of the scene's schema: the robot model, the options of the
robot effects (``motors``, ``contact``, ``friction``), the motors' ranges of the input
laws and the fixed step the robot's cables allow.

Functions over the scene's :class:`~tensegrity_core.schema.Reader` (its errors are
:class:`~tensegrity_core.sim.errors.SceneError` with key path and line), called by
:class:`~tensegrity_core.sim.scene.schema.SceneReader`. Lengths in metres, times in seconds,
forces in newtons.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.motor import MODES, REEL_SPEED, REST_LENGTH, TENSION
from tensegrity_core.schema import KeyPath, Reader, excerpt, suggest, type_name
from tensegrity_core.sim.inputs import Commanded, Constant, InputLaw, Ramp
from tensegrity_core.sim.scene.references import robot_source
from tensegrity_core.sim.scene.spec import (
    ContactSpec,
    EffectSpec,
    FrictionSpec,
    ModelSpec,
    MotorsSpec,
    RobotModelSpec,
    RollSpec,
    SceneEffects,
)

IntArray = NDArray[np.int64]


def robot_model(reader: Reader, d: dict[str, Any], path: KeyPath, base: Path) -> RobotModelSpec:
    """``model`` of ``kind: robot``: the robot (a shipped robot's name, a file relative to
    ``base`` or the description inline) and the end effector (a node's name; default the
    last node)."""
    from tensegrity_core.robot.description import RobotError
    from tensegrity_core.robot.loading import robot_from_file
    from tensegrity_core.robot.robot_schema import robot_from_dict
    from tensegrity_core.sim.errors import SceneError

    reader.keys(d, path, ("kind", "robot", "end_effector"), required=("robot",))
    value = d["robot"]
    if not isinstance(value, (dict, str)):
        raise reader.error(f"must be a shipped robot's name, a file path or a mapping, got {type_name(value)}",
                           path + ("robot",), d, "robot")
    try:
        source = robot_source(value, base)
    except SceneError as err:
        raise reader.error(err.reason, path + ("robot",), d, "robot") from None
    try:
        if source.data is not None:
            robot, name = robot_from_dict(source.data), "inline"
        else:
            assert source.path is not None              # a mapping or a file, as robot_source says
            robot = robot_from_file(source.path)
            name = source.path.stem if source.shipped is not None else str(source.path)
    except RobotError as err:
        if isinstance(value, dict):          # inline: the robot's own key path and line in this file
            raise reader.error_class(f"invalid robot: {err.reason}", key=path + ("robot",) + tuple(err.key),
                                     line=err.line, file=reader.file) from None
        raise reader.error_class(f"invalid robot: {err}", key=path + ("robot",), file=reader.file) from None
    if "end_effector" in d:
        ee = reader.string(d, "end_effector", path)
        if ee not in robot.node_names:
            raise reader.error(f"unknown node {excerpt(ee)}{suggest(ee, robot.node_names)}",
                               path + ("end_effector",), d, "end_effector")
        end_effector = robot.node_names.index(ee)
    else:
        end_effector = int(robot.n_nodes - 1)
    return RobotModelSpec(robot, name, end_effector, tuple(int(i) for i in robot.cables.actuated))


def robot_effect(reader: Reader, name: str, d: dict[str, Any], path: KeyPath, model: RobotModelSpec) -> EffectSpec:
    """The options of a robot's ``motors``, ``contact`` or ``friction``: each replaces the
    description's value (every motor's, the floor's), a size as in the description
    (:func:`~tensegrity_core.robot.robot_schema.size_reason`)."""
    effect = _robot_effect(reader, name, d, path, model)
    from tensegrity_core.robot.robot_schema import SIZE_UNITS, size_reason

    for key, value in d.items():
        if key in SIZE_UNITS and isinstance(value, (int, float)) and not isinstance(value, bool):
            reason = size_reason(float(value), key)
            if reason is not None:
                raise reader.error(reason, path + (key,), d, key)
    return effect


def _robot_effect(reader: Reader, name: str, d: dict[str, Any], path: KeyPath, model: RobotModelSpec) -> EffectSpec:
    if name == "motors":
        reader.keys(d, path, ("tau", "max_speed", "max_tension", "modes"))
        tau = reader.number(d, "tau", path, unit="s", lo=0.0) if "tau" in d else None
        speed = reader.number(d, "max_speed", path, unit="m/s", lo=0.0, lo_open=True, allow_inf=True) \
            if "max_speed" in d else None
        tension = reader.number(d, "max_tension", path, unit="N", lo=0.0, lo_open=True, allow_inf=True) \
            if "max_tension" in d else None
        return MotorsSpec(tau, speed, tension, motor_modes(reader, d, path, model) if "modes" in d else ())
    floor = model.robot.floor
    if floor is None:
        raise reader.error(f"robot {excerpt(model.robot.name)} has no floor for {name!r} (give its description a "
                           f"'floor')", path, d, None)
    if name == "contact":
        reader.keys(d, path, ("stiffness", "dissipation"))
        return ContactSpec(reader.number(d, "stiffness", path, unit="N/m", default=floor.stiffness, lo=0.0, lo_open=True),
                           reader.number(d, "dissipation", path, unit="s/m", default=floor.dissipation, lo=0.0))
    reader.keys(d, path, ("mu_static", "mu_kinetic", "tangential_stiffness", "tangential_damping", "rolling_friction",
                          "torsional_friction"))
    mu_s = reader.number(d, "mu_static", path, unit="", default=floor.mu_static, lo=0.0)
    mu_k = reader.number(d, "mu_kinetic", path, unit="", default=min(floor.mu_kinetic, mu_s), lo=0.0)
    if mu_k > mu_s:
        raise reader.error(f"mu_kinetic = {mu_k:g} must not exceed mu_static = {mu_s:g}", path + ("mu_kinetic",),
                           d, "mu_kinetic")
    return FrictionSpec(mu_s, mu_k,
                        reader.number(d, "tangential_stiffness", path, unit="N/m", default=floor.tangential_stiffness, lo=0.0,
                                      lo_open=True),
                        reader.number(d, "tangential_damping", path, unit="N s/m", default=floor.tangential_damping, lo=0.0),
                        reader.number(d, "rolling_friction", path, unit="m", default=floor.rolling_friction, lo=0.0),
                        reader.number(d, "torsional_friction", path, unit="m", default=floor.torsional_friction, lo=0.0))


def robot_control(reader: Reader, d: dict[str, Any], model: ModelSpec) -> RollSpec:
    """``control`` of a robot scene: ``{roll: {faces, heading, rate}}``, the closed-loop
    rolling gait that commands every motor (so the scene gives no ``inputs``): ``faces`` new
    faces (>= 1) towards ``heading`` (a nonzero (x, y) on the floor; default +x), sampled at
    ``rate`` [Hz] (default 50)."""
    path: KeyPath = ("control",)
    if not isinstance(model, RobotModelSpec):
        raise reader.error(f"'control' applies to robot scenes only (model kind 'robot'), not {model.kind!r}",
                           path, d, "control")
    c = reader.mapping(d["control"], path, d, "control")
    reader.keys(c, path, ("roll",), required=("roll",))
    if "inputs" in d:
        raise reader.error("the closed-loop gait commands every motor: give 'control' or 'inputs', not both",
                           path, d, "control")
    path += ("roll",)
    r = reader.mapping(c["roll"], path, c, "roll")
    reader.keys(r, path, ("faces", "heading", "rate"), required=("faces",))
    faces = reader.integer(r, "faces", path, lo=1)
    heading = reader.vector(r["heading"], 2, path + ("heading",), r, "heading", unit="") if "heading" in r else (1.0, 0.0)
    if not math.hypot(*heading) > 0:
        raise reader.error(f"must be a nonzero direction (x, y) on the floor, got {list(heading)}",
                           path + ("heading",), r, "heading")
    rate = reader.number(r, "rate", path, unit="Hz", default=50.0, lo=0.0, lo_open=True)
    return RollSpec(faces, (heading[0], heading[1]), rate)


def control_rate_reason(rate: float, step: float) -> str | None:
    """Why a controller cannot be sampled at ``rate`` [Hz] on a model taking fixed steps of
    ``step`` [s] (0: adaptive steps, any rate), or None when it can. Above ``1 / step`` it
    cannot: the motors take a new command at the start of a step, so samples between two
    steps see the same state and command nothing new (and each costs an evaluation: at 1 MHz
    a 10 ms run took 40 s)."""
    if not (rate > 0 and math.isfinite(rate)):
        return f"the control rate must be a positive number of Hz, got {rate!r}"
    if step > 0 and rate * step > 1.0 + 1e-12:
        return (f"a controller sampled at {rate:g} Hz is faster than the robot's fixed step of {step:g} s "
                f"({1.0 / step:g} Hz), at which its commands act; give rate in (0, {1.0 / step:g}] Hz")
    return None


def control_rate_fits(reader: Reader, control: RollSpec, step: float, d: dict[str, Any]) -> None:
    """Refuse a control rate [Hz] the robot's fixed step ``step`` [s] cannot take
    (:func:`control_rate_reason`)."""
    reason = control_rate_reason(control.rate, step)
    if reason is None:
        return
    path: KeyPath = ("control", "roll", "rate")
    r = d["control"]["roll"]
    raise reader.error(reason, path, r, "rate" if "rate" in r else None)


def motor_modes(reader: Reader, d: dict[str, Any], path: KeyPath, model: RobotModelSpec) -> tuple[tuple[str, int], ...]:
    """``motors.modes``: a mapping from actuated cables' names to their motors' modes."""
    robot = model.robot
    actuated = tuple(robot.cables.names[int(i)] for i in robot.cables.actuated)
    m = reader.mapping(d["modes"], path + ("modes",), d, "modes")
    out = []
    for name in m:
        if name not in actuated:
            raise reader.error(f"{excerpt(name)} is not an actuated cable{suggest(str(name), actuated)}; actuated: "
                               f"{', '.join(actuated)}", path + ("modes", name), m, name)
        out.append((str(name), MODES[reader.string(m, name, path + ("modes",), choices=tuple(MODES))]))
    return tuple(out)


def modes_of(robot: Robot, motors: MotorsSpec | None) -> IntArray:
    """(a,) each motor's mode (:data:`~tensegrity_core.robot.motor.MODES`' values): the
    description's, replaced by the scene's ``motors.modes``."""
    modes = robot.motors.mode.copy()
    for name, mode in motors.modes if motors is not None else ():
        modes[int(robot.cables.motor[robot.cables.names.index(name)])] = mode
    return modes


def within_motor_ranges(reader: Reader, laws: dict[str, InputLaw], model: RobotModelSpec, path: KeyPath,
                        d: dict[str, Any], motors: MotorsSpec | None) -> None:
    """Every command a robot's input law gives lies in its motor's range: a rest length [m]
    in the rest-length range, a reel speed [m/s] within the slew limit, a tension [N] in
    ``[0, max_tension]`` (the scene's ``motors`` values where given)."""
    robot = model.robot
    modes = modes_of(robot, motors)
    for name, law in laws.items():
        cable = robot.cables.names.index(name)
        j = int(robot.cables.motor[cable])
        lo, hi = command_range(robot, j, int(modes[j]), motors)
        values: tuple[float, ...]
        if isinstance(law, Constant):
            values = (law.value,)
        elif isinstance(law, Ramp):
            values = (law.start_value, law.end_value)
        elif isinstance(law, Commanded):
            values = () if law.initial is None else (law.initial,)
        else:
            values = tuple(getattr(law, "values", ()))
        bad = [v for v in values if not lo <= v <= hi]
        if bad:
            where = path + (name,) if name in d else path + ("gait",)
            what, unit = COMMAND_WORDS[int(modes[j])]
            raise reader.error(f"{what} {bad[0]:g} {unit} of cable {excerpt(name)} is outside its motor's range "
                               f"[{lo:g}, {hi:g}] {unit}", where, d, where[-1])


#: Per motor mode, what a command is called and its unit.
COMMAND_WORDS: dict[int, tuple[str, str]] = {REST_LENGTH: ("rest length", "m"), REEL_SPEED: ("reel speed", "m/s"),
                                             TENSION: ("tension", "N")}


def command_range(robot: Robot, j: int, mode: int, motors: MotorsSpec | None) -> tuple[float, float]:
    """The closed interval a command of motor ``j`` in ``mode`` must lie in: its rest-length
    range [m], ``[-max_speed, max_speed]`` [m/s], ``[0, max_tension]`` [N] (the scene's
    ``motors`` values replacing the description's where given)."""
    if mode == REEL_SPEED:
        s = motors.max_speed if motors is not None and motors.max_speed is not None else robot.motors.max_speed[j]
        return -float(s), float(s)
    if mode == TENSION:
        t = motors.max_tension if motors is not None and motors.max_tension is not None \
            else robot.motors.max_tension[j]
        return 0.0, float(t)
    lo, hi = robot.motors.range[j]
    return float(lo), float(hi)


def rotation_mode(robot: Robot, rod: int, taut: list[int], g: NDArray[np.float64]) -> tuple[float, float, int] | None:
    """``(omega^2 [1/s^2], I [kg m^2], cable)``: a lower bound on the square of the fastest
    mode of the robot as drawn from turning rod ``rod`` about its centre (by ``theta`` about
    an axis ``e`` across it), its transverse inertia about the centre ``I`` (its own and its
    caps' point masses') and the cable whose direction gave the axis; None when no axis
    gives a positive bound.

    The cap at ``r`` from the centre moves by ``theta e x r + theta^2/2 e x (e x r)``; a taut
    cable from it along ``u`` (stiffness ``k``, tension ``T``) then stores
    ``theta^2/2 (k (u . (e x r))^2 + T u . r)`` (its stretch, and the arc shortening it by
    ``theta^2/2 u . r``), plus its transverse stiffness ``T / l`` (left out: it only adds);
    a point mass's weight ``W`` at the cap ``theta^2/2 W . r``. The Rayleigh quotient of that
    sum over ``I`` bounds ``omega^2`` from below (the cables to the rod's other end held
    still). Axes: across the rod, normal to each cable's plane with it, and the rod's two
    frame axes. A cable pulling a cap outward along the rod (``u . r = L/2``) gives
    ``T L / (2 I)``: the rod swinging to align with it."""
    a, b = (int(x) for x in robot.rods.ends[rod])
    centre = 0.5 * (robot.nodes[a] + robot.nodes[b])
    axis = robot.nodes[b] - robot.nodes[a]
    length = float(np.linalg.norm(axis))
    axis /= length
    riders = robot.node_masses[[a, b]]
    inertia = float(robot.rods.inertia[rod, 0] + riders.sum() * (length / 2) ** 2)
    cables = robot.cables
    ends, k, T, r, u = [], [], [], [], []
    for i in taut:
        ca, cb = (int(x) for x in cables.ends[i])
        for end, other in ((ca, cb), (cb, ca)):
            if end in (a, b) and other not in (a, b):
                d = robot.nodes[other] - robot.nodes[end]
                l = float(np.linalg.norm(d))
                ends.append(i)
                k.append(float(cables.stiffness[i]))
                T.append(float(cables.stiffness[i]) * (l - float(cables.rest_length[i])))
                r.append(robot.nodes[end] - centre)
                u.append(d / l)
    if not ends:
        return None
    K, Tn, R, U = np.array(k), np.array(T), np.array(r), np.array(u)
    weight = sum(float(m) * float(g @ (robot.nodes[n] - centre)) for n, m in zip((a, b), riders))
    frame = np.linalg.svd(axis[None])[2][1:]                   # two unit axes across the rod
    best: tuple[float, float, int] | None = None
    for j, i in enumerate(ends):
        trial = np.cross(R[j], U[j])
        trial -= (trial @ axis) * axis
        size = float(np.linalg.norm(trial))
        for e in ([trial / size] if size > 1e-12 * length else []) + list(frame):
            stored = float(np.sum(K * np.einsum("ij,ij->i", U, np.cross(e, R)) ** 2 + Tn * np.einsum("ij,ij->i", U, R)))
            omega2 = (stored + weight) / inertia
            if omega2 > 0 and (best is None or omega2 > best[0]):
                best = (omega2, inertia, i)
    return best


#: Where the classical RK4's stability region ``|R(z)| <= 1``, ``R(z) = 1 + z + z^2/2 + z^3/6
#: + z^4/24``, meets the imaginary axis [1]: ``|R(iy)|^2 = 1 - y^6/72 + y^8/576`` is at most 1
#: exactly while ``y^2 <= 8``, so an undamped mode (``z = +-i h omega``) grows from
#: ``h omega = 2 sqrt 2 = 2.83`` on (the region reaches 2.96 in between and 2.79 along the
#: negative real axis).
RK4_IMAGINARY_REACH = 2.0 * math.sqrt(2.0)


def _rk4_growth(z: complex) -> float:
    return abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) - 1.0


@functools.lru_cache(maxsize=1024)      # a robot's cables share a few damping ratios
def rk4_reach(zeta: float) -> float:
    """The largest ``h omega`` [1] at which RK4 keeps a linear mode of natural frequency
    ``omega`` [rad/s] and damping ratio ``zeta >= 0`` [1] from growing: the stability
    region's radius along the mode's roots ``omega (-zeta +- i sqrt(1 - zeta^2))`` (modulus
    ``omega``), or for ``zeta > 1`` its reach along the negative real axis over the fast
    root's ``zeta + sqrt(zeta^2 - 1)``. ``rk4_reach(0)`` is :data:`RK4_IMAGINARY_REACH`."""
    from scipy.optimize import brentq

    if zeta <= 0.0:
        return RK4_IMAGINARY_REACH
    if zeta >= 1.0:
        return float(brentq(lambda r: _rk4_growth(-r), 1.0, 3.0)) / (zeta + math.sqrt(zeta * zeta - 1.0))
    root = complex(-zeta, math.sqrt(1.0 - zeta * zeta))
    return float(brentq(lambda r: _rk4_growth(r * root), 1.0, 3.0))


def impact_speed(robot: Robot, lift: float, g: NDArray[np.float64], normal: NDArray[np.float64]) -> float:
    """The speed [m/s] at which a robot released at rest as drawn, raised ``lift`` [m] along
    the floor's normal ``n``, first touches the floor under gravity ``g`` [m/s^2]: until then
    gravity is its only external force, so its centre of mass falls ``lift`` freely and meets
    it at ``sqrt(2 |g . n| lift)`` (a drawing at rest falls as one body; 0 for a robot with
    pinned nodes, which does not fall)."""
    if robot.pinned.any():
        return 0.0
    return math.sqrt(2.0 * abs(float(g @ normal)) * max(lift, 0.0))


def cap_mass(robot: Robot, rod: int) -> float:
    """The least effective mass [kg] of a cap of rod ``rod`` pushed along the floor's normal,
    over every orientation the rod can land in: moving the cap by ``e`` along a unit ``n``
    costs at least the kinetic energy of ``m_eff e'^2 / 2``, ``1 / m_eff = 1/m + (L/2)^2 |n x
    a|^2 / I`` (the rod's mass ``m`` and transverse inertia ``I`` about its centre, the point
    masses at its caps included, its unit axis ``a``, half-length ``L/2``): the cap's push is
    shared by the rod's translation and its turning, and a rod lying along the floor (``|n x
    a| = 1``, the least) turns most. So the floor's contact stiffness ``k`` under that cap
    alone gives a mode of at least ``sqrt(k / m_eff)`` (Rayleigh), however the robot tumbles."""
    a, b = (int(x) for x in robot.rods.ends[rod])
    half = 0.5 * float(np.linalg.norm(robot.nodes[b] - robot.nodes[a]))
    riders = robot.node_masses[[a, b]]
    mass = float(robot.rods.mass[rod] + riders.sum())
    inertia = float(robot.rods.inertia[rod, 0] + riders.sum() * half**2)
    return 1.0 / (1.0 / mass + half**2 / inertia)


def contact_point_mass(robot: Robot, rod: int) -> float:
    """The effective mass [kg] of the contact point of a cap of rod ``rod`` lying along the
    floor, pushed along the floor across the rod's axis (the friction anchor's force there):
    the point is ``rho = (L/2) a - r n`` from the rod's centre (cap radius ``r``), and a force
    along a unit ``t`` (``t``, ``a`` and ``n`` orthogonal) turns the rod about ``n`` with the
    lever ``L/2`` and spins it about its axis with the lever ``r``, so ``1 / m_eff = 1/m +
    (L/2)^2 / I_t + r^2 / I_a`` (transverse and axial inertias about the centre, the point
    masses at the caps in ``m`` and ``I_t``; on the axis they add nothing to ``I_a``). The
    axial term dominates a rod: a thin rod's ``I_a`` is small, so its caps' friction anchor
    meets a fast spin mode. The anchor's stiffness ``k_t`` gives a mode of at least
    ``sqrt(k_t / m_eff)`` (Rayleigh), its damping ``c_t`` the rate ``c_t / m_eff``."""
    a, b = (int(x) for x in robot.rods.ends[rod])
    half = 0.5 * float(np.linalg.norm(robot.nodes[b] - robot.nodes[a]))
    riders = robot.node_masses[[a, b]]
    mass = float(robot.rods.mass[rod] + riders.sum())
    inertia = float(robot.rods.inertia[rod, 0] + riders.sum() * half**2)
    radius = float(robot.rods.cap_radius[rod])
    return 1.0 / (1.0 / mass + half**2 / inertia + radius**2 / float(robot.rods.inertia[rod, 1]))


def step_fits(reader: Reader, model: RobotModelSpec, effects: SceneEffects, step: float,
              d: dict[str, Any], lift: float = 0.0) -> None:
    """Refuse a fixed step ``step`` [s] that RK4 cannot follow on the robot as drawn, with
    its ``effects``.

    Moving a free rod of mass ``m`` [kg] (its own and the point masses at its caps) by ``e``
    along a unit direction ``u`` stores at least ``sum k_i (u_i . u)^2 e^2 / 2`` in the taut
    cables ``i`` (stiffness ``k_i`` [N/m], direction ``u_i``, below their motors' tension
    limits) that join it to anything but itself; the cables' geometric stiffness and
    everything else only add. So the undamped linearisation at the drawing has a mode of at
    least ``omega = sqrt(sum k_i (u_i . u)^2 / m)`` (Rayleigh), taken here for ``u`` along each
    of those cables; with damping the fast root of a mode is at least as large. Likewise a cap
    on the floor (``contact``: its normal force ``k delta`` [N/m] while it presses in; with
    ``friction``, the sticking anchor's ``tangential_stiffness``) gives the rod moved along
    the normal (or along the floor) a mode of at least ``sqrt(k / m)`` once it touches, and
    turning a rod about its centre into its taut cables a mode of at least
    :func:`rotation_mode`'s (a rod swinging to align with a cable's pull). RK4
    with steps ``h`` diverges on a mode once ``h omega`` exceeds its reach: such a run would stop
    with a state that is no longer finite, so the scene is refused before it starts, naming
    the rod, what holds it and the longest step that mode allows (a step below it may still
    be too long for a mode this bound does not see; the run then stops and says so). A cap
    meeting the floor at ``deltadot`` feels the Hunt-Crossley force ``k delta (1 + d deltadot)``
    stiffen to ``k (1 + d deltadot)`` while it presses in: the floor's mode is taken at the
    speed of the first touch-down (:func:`impact_speed`; later bounces may be faster), where a
    step that suits ``k`` alone gains energy at the bounce.
    RK4's reach is :func:`rk4_reach` of the mode's damping ratio ``c / (2 m omega)``: the
    taut cables' damping ``c_i`` [N s/m] along the same direction (``sum c_i (u_i . u)^2``),
    the friction anchor's ``tangential_damping``; an undamped mode (a rod turning, whose
    cables' lengths change only to second order; a cap just touching, where Hunt-Crossley
    damping ``k delta d`` is zero) has :data:`RK4_IMAGINARY_REACH`."""
    robot = model.robot
    motors, contact, friction = effects.get("motors"), effects.get("contact"), effects.get("friction")
    pinned: NDArray[np.bool_] = np.asarray(robot.pinned.any(axis=1), dtype=bool)
    in_body = {int(i) for b in robot.bodies for i in b.nodes}
    rod_of: dict[int, int] = {}
    for j, (a, b) in enumerate(robot.rods.ends.tolist()):
        if not (pinned[a] or pinned[b] or a in in_body or b in in_body):
            rod_of[a] = rod_of[b] = j
    limit = robot.motors.max_tension if motors is not None else np.full(len(robot.motors), math.inf)
    if motors is not None and motors.max_tension is not None:
        limit = np.full(len(robot.motors), motors.max_tension)
    cables = robot.cables
    h = robot.nodes[cables.ends[:, 1]] - robot.nodes[cables.ends[:, 0]]
    drawn = np.linalg.norm(h, axis=1)
    on: dict[int, list[int]] = {}                      # rod -> its taut cables to other things
    for i, (a, b) in enumerate(cables.ends.tolist() if "cables" in effects else ()):
        k, l0 = float(cables.stiffness[i]), float(cables.rest_length[i])
        t_max = float(limit[cables.motor[i]]) if cables.motor[i] >= 0 else math.inf
        if not (drawn[i] > l0 and k * (drawn[i] - l0) < t_max):
            continue                                   # slack, or paying out at its limit
        for end, other in ((a, b), (b, a)):
            rod = rod_of.get(end)
            if rod is not None and rod_of.get(other) != rod:
                on.setdefault(rod, []).append(i)
    worst: tuple[float, float, float, int, str] | None = None   # longest step [s], omega, m, rod, what holds it

    def consider(rod: int, stiffness: float, what: str, damping: float = 0.0, mass: float = 0.0) -> None:
        """The mode of ``stiffness`` [N/m] on ``mass`` [kg] (default: the whole rod's)."""
        nonlocal worst
        whole = float(robot.rods.mass[rod] + robot.node_masses[robot.rods.ends[rod]].sum())
        mass = mass or whole
        omega = math.sqrt(stiffness / mass)
        longest = rk4_reach(damping / (2.0 * mass * omega)) / omega
        if worst is None or longest < worst[0]:
            worst = (longest, omega, whole, rod, what)

    for rod, taut in on.items():
        u = h[taut] / drawn[taut, None]
        k_taut, c_taut = cables.stiffness[taut], cables.damping[taut]
        for j, i in enumerate(taut):
            share = (u @ u[j]) ** 2
            stiffness = float(np.sum(k_taut * share))
            consider(rod, stiffness, f"moved along cable {excerpt(cables.names[i])} it meets {stiffness:g} N/m of "
                                     f"taut cables", float(np.sum(c_taut * share)))
    gravity = effects.get("gravity")
    g = np.zeros(3) if gravity is None else np.asarray(gravity.vector, dtype=float)
    for rod, taut in on.items():
        turning = rotation_mode(robot, rod, taut, g)
        if turning is not None:
            omega2, inertia, i = turning
            stiffness = omega2 * float(robot.rods.mass[rod] + robot.node_masses[robot.rods.ends[rod]].sum())
            consider(rod, stiffness, f"turned towards cable {excerpt(cables.names[i])} (its transverse inertia "
                                     f"{inertia:g} kg m^2) it meets {omega2 * inertia:g} N m/rad of taut cables")
    for rod in sorted(set(rod_of.values())):
        if contact is not None and robot.floor is not None:
            normal = robot.floor.normal
            speed = impact_speed(robot, lift, g, normal) if contact.dissipation > 0.0 else 0.0
            stiff = contact.stiffness * (1.0 + contact.dissipation * speed)
            m_cap = cap_mass(robot, rod)
            consider(rod, stiff, mass=m_cap, what=f"a cap pressed into the floor ({m_cap:.3g} kg of the rod moving "
                                                  f"with it) meets {contact.stiffness:g} N/m of contact stiffness"
                                 + (f" (with its dissipation {contact.dissipation:g} s/m, {stiff:.4g} N/m at up to "
                                    f"{speed:.3g} m/s)" if speed > 0.0 else ""))
        if friction is not None:
            m_t = contact_point_mass(robot, rod)
            consider(rod, friction.tangential_stiffness, mass=m_t, damping=friction.tangential_damping,
                     what=f"a cap sticking on the floor ({m_t:.3g} kg of the rod moving with its contact point, "
                          f"spinning it) meets {friction.tangential_stiffness:g} N/m and "
                          f"{friction.tangential_damping:g} N s/m of friction anchor")
    if worst is None or step <= worst[0]:
        return
    longest, omega, mass, rod, what = worst
    longest = _at_most(longest)
    given = isinstance(d.get("integrator"), dict) and "max_step" in d["integrator"]
    path: KeyPath = ("integrator", "max_step")
    raise reader.error(f"a fixed step of {step:g} s{'' if given else ' (the default)'} is too long for rod "
                       f"{excerpt(robot.rods.names[rod])} ({mass:g} kg): {what}, a mode of at least {omega:.4g} rad/s, which RK4 follows with steps up to {longest:.3g} s; give "
                       f"integrator.max_step in (0, {longest:.3g}] s",
                       path, d["integrator"] if given else d, "max_step" if given else "integrator")


def _at_most(x: float) -> float:
    """``x`` > 0 to 3 significant digits, rounded down: the longest step a refusal suggests
    must itself be accepted."""
    unit = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.floor(x / unit) * unit
