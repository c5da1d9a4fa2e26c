"""The immutable description of a tensegrity robot: nodes, rods, cables, motors, sensors, floor.

A :class:`Robot` holds what does not change while the robot moves (MuJoCo's model, not its
data): node names and the drawn coordinates [m], and per kind of part a table of columns
(plain arrays, so the dynamics' kernels take them as they are):

- :class:`Rods`: end-cap node pairs, total mass [kg], capsule and cap radii [m], inertia
  ``(I_t, I_a)`` about the centre [kg m^2] (:mod:`.rod`);
- :class:`Cables`: node pairs, stiffness [N/m], damping [N s/m], rest length [m] as drawn
  (the motors' initial state for actuated cables), and the index of each cable's motor
  (-1: passive);
- :class:`Motors`: per actuated cable the rest-length range [m], lag [s], slew limit [m/s]
  and tension limit [N] (:mod:`.motor`);
- :class:`Floor` (or None): the plane and its contact and friction parameters
  (:mod:`.contact`, :mod:`.friction`);
- :class:`Sensors`: which cables report their length and tension, which rods and bodies
  carry an IMU (:mod:`.imu`).

Rigid bodies other than rods (a spine's vertebrae), supports, point masses and gravity are
those of the structure format. :meth:`Robot.structure` is the robot as the statics see it:
rods as bars far stiffer than any cable, cables as strings of ``EA = k l0``
(:func:`~tensegrity_core.robot.cable.statics_EA`), so form-finding, stiffness and stability
run on the robot's own cable element.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.general.structure import RigidBody, Structure
from tensegrity_core.robot.cable import statics_EA
from tensegrity_core.schema import MAX_MAGNITUDE, SchemaError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: In the statics a rod is a bar whose axial stiffness ``EA / L`` is this many times the
#: stiffest cable's, ``k_max``: it stands for a rigid rod (two nodes cannot make a rigid body
#: of the structure format). How rigid it must be: a rod carrying the force ``C`` [N] changes
#: its length by ``C / (ROD_STIFFNESS_RATIO k_max)``, and ``C`` is what the cables at one of
#: its caps pull (and the weight there), at most ``k_max`` times the sum ``e`` [m] of their
#: stretches; so the statics' rods are off their length by at most ``e / ROD_STIFFNESS_RATIO``
#: (plus the weight's share), and the rest shape by that much: 1e-4 of the cables' stretch,
#: below the 1e-5 of the rod length the statics state (the six-bar's rods, 441 N on
#: 4e7 N/m: 1.1e-5 m of 1.7 m, docs/robots.md). Stiffer bars gain nothing measurable and push
#: the rods' forces, ``EA`` times a strain known to 1e-16, into the rounding of the residual.
ROD_STIFFNESS_RATIO = 1.0e4


def statics_force_unit(EA: ArrayLike) -> float:
    """The force unit [N] of the statics' structure for members of axial stiffness ``EA`` [N]:
    1, or the least power of two that brings the largest within the structure format's
    bound (:data:`~tensegrity_core.schema.MAX_MAGNITUDE`). The equilibria are those of
    stiffnesses and loads divided alike, and a power of two divides without rounding, so a
    robot with cables up to 1e15 N/m (its rods' stand-ins 1e4 times stiffer) has the same
    statics in this unit as in newtons."""
    largest = float(np.max(EA))
    if not largest > MAX_MAGNITUDE:
        return 1.0
    return float(2.0 ** math.ceil(math.log2(largest / MAX_MAGNITUDE)))


class RobotError(SchemaError):
    """A robot description is invalid: ``key`` the key path, ``line`` and ``file`` where
    known (see :class:`~tensegrity_core.schema.SchemaError`)."""


def _frozen(a: ArrayLike, dtype: type = float) -> NDArray[np.generic]:
    out: NDArray[np.generic] = np.array(a, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Rods:
    """The rods: ``ends`` (r, 2) node indices, ``mass`` (r,) total [kg], ``radius`` (r,)
    capsule radius [m], ``cap_radius`` (r,) end-cap (contact) radius [m], ``inertia`` (r, 2)
    ``(I_t, I_a)`` about the centre [kg m^2]."""

    names: tuple[str, ...]
    ends: IntArray
    mass: FloatArray
    radius: FloatArray
    cap_radius: FloatArray
    inertia: FloatArray

    def __post_init__(self) -> None:
        for name, dtype in (("ends", np.int64), ("mass", float), ("radius", float), ("cap_radius", float),
                            ("inertia", float)):
            object.__setattr__(self, name, _frozen(getattr(self, name), dtype).reshape((-1, 2) if name in (
                "ends", "inertia") else (-1,)))

    def __len__(self) -> int:
        return len(self.names)


@dataclass(frozen=True, eq=False)
class Cables:
    """The cables: ``ends`` (c, 2) node indices, ``stiffness`` [N/m], ``damping`` [N s/m],
    ``rest_length`` [m] as drawn, ``motor`` (c,) index into :class:`Motors` or -1."""

    names: tuple[str, ...]
    ends: IntArray
    stiffness: FloatArray
    damping: FloatArray
    rest_length: FloatArray
    motor: IntArray

    def __post_init__(self) -> None:
        object.__setattr__(self, "ends", _frozen(self.ends, np.int64).reshape(-1, 2))
        for name in ("stiffness", "damping", "rest_length"):
            object.__setattr__(self, name, _frozen(getattr(self, name)).reshape(-1))
        object.__setattr__(self, "motor", _frozen(self.motor, np.int64).reshape(-1))

    def __len__(self) -> int:
        return len(self.names)

    @property
    def actuated(self) -> IntArray:
        """Indices of the actuated cables, in motor order."""
        order: IntArray = np.argsort(np.where(self.motor >= 0, self.motor, len(self.motor) + 1))
        return order[: int((self.motor >= 0).sum())]


@dataclass(frozen=True, eq=False)
class Motors:
    """One motor per actuated cable: ``cable`` (a,) cable index, ``range`` (a, 2) rest-length
    limits [m], ``tau`` lag [s] (0: none), ``max_speed`` [m/s] (inf: none), ``max_tension``
    [N] (inf: none), ``mode`` (a,) what its command is (:data:`.motor.MODES`: rest length
    [m], reel speed [m/s] or tension [N])."""

    cable: IntArray
    range: FloatArray
    tau: FloatArray
    max_speed: FloatArray
    max_tension: FloatArray
    mode: IntArray

    def __post_init__(self) -> None:
        object.__setattr__(self, "cable", _frozen(self.cable, np.int64).reshape(-1))
        object.__setattr__(self, "mode", _frozen(self.mode, np.int64).reshape(-1))
        object.__setattr__(self, "range", _frozen(self.range).reshape(-1, 2))
        for name in ("tau", "max_speed", "max_tension"):
            object.__setattr__(self, name, _frozen(getattr(self, name)).reshape(-1))

    def __len__(self) -> int:
        return len(self.cable)


@dataclass(frozen=True, eq=False)
class Floor:
    """A floor plane through ``point`` with unit ``normal`` (out of the ground); normal
    contact ``stiffness`` [N/m] and Hunt-Crossley ``dissipation`` [s/m]; friction
    coefficients ``mu_static`` >= ``mu_kinetic``; the friction anchor's
    ``tangential_stiffness`` [N/m] and ``tangential_damping`` [N s/m]; the lever arms [m] of
    the caps' ``rolling_friction`` and ``torsional_friction`` (MuJoCo's rolling and torsional
    coefficients: the resisting couples' limits per newton of normal force,
    :mod:`tensegrity_core.robot.contact`)."""

    normal: FloatArray
    point: FloatArray
    stiffness: float
    dissipation: float
    mu_static: float
    mu_kinetic: float
    tangential_stiffness: float
    tangential_damping: float
    rolling_friction: float = 0.0
    torsional_friction: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "normal", _frozen(self.normal))
        object.__setattr__(self, "point", _frozen(self.point))

    def heights(self, points: ArrayLike) -> FloatArray:
        """Signed heights [m] of ``points`` (n, 3) above the plane."""
        out: FloatArray = (np.asarray(points, dtype=float) - self.point) @ self.normal
        return out


@dataclass(frozen=True)
class Sensors:
    """What the robot measures: the cables whose ``cable_length`` and ``cable_tension`` it
    reports (cable indices), the rods (``imu_rods``) and other rigid bodies (``imu_bodies``,
    indices into :attr:`Robot.bodies`) that carry an IMU at their centre."""

    cable_length: tuple[int, ...] = ()
    cable_tension: tuple[int, ...] = ()
    imu_rods: tuple[int, ...] = ()
    imu_bodies: tuple[int, ...] = ()


@dataclass(frozen=True, eq=False)
class Robot:
    """A checked robot description (see the module docstring); build it with
    :func:`~tensegrity_core.robot.loading.load_robot` and friends."""

    name: str
    node_names: tuple[str, ...]
    nodes: FloatArray
    rods: Rods
    cables: Cables
    motors: Motors
    sensors: Sensors
    floor: Floor | None = None
    bodies: tuple[RigidBody, ...] = ()
    pinned: NDArray[np.bool_] = field(default_factory=lambda: np.zeros((0, 3), dtype=bool))
    node_masses: FloatArray = field(default_factory=lambda: np.zeros(0))
    gravity: FloatArray = field(default_factory=lambda: np.zeros(3))
    description: str = ""

    def __post_init__(self) -> None:
        n = len(self.node_names)
        object.__setattr__(self, "nodes", _frozen(self.nodes).reshape(-1, 3))
        object.__setattr__(self, "pinned", _frozen(self.pinned if len(self.pinned) else np.zeros((n, 3)), bool))
        object.__setattr__(self, "node_masses", _frozen(self.node_masses if len(self.node_masses) else np.zeros(n)))
        object.__setattr__(self, "gravity", _frozen(self.gravity))

    @property
    def n_nodes(self) -> int:
        return len(self.node_names)

    @property
    def member_names(self) -> tuple[str, ...]:
        """The statics' members: the rods, then the cables."""
        return self.rods.names + self.cables.names

    def cable_members(self) -> IntArray:
        """Member indices of the cables in :meth:`structure` (after the rods)."""
        out: IntArray = len(self.rods) + np.arange(len(self.cables))
        return out

    def rod_lengths(self) -> FloatArray:
        """Rod lengths [m] between the cap centres, as drawn."""
        e = self.rods.ends
        out: FloatArray = np.linalg.norm(self.nodes[e[:, 1]] - self.nodes[e[:, 0]], axis=1)
        return out

    def lumped_masses(self) -> FloatArray:
        """(n,) masses [kg] lumped at the nodes, where the weights act: point masses, half of
        each rod's mass at each of its caps (exact for the weight of a symmetric rod), each
        other body's mass shared equally by its nodes (their centre of mass is the robot's)."""
        m = np.array(self.node_masses, dtype=float)
        np.add.at(m, self.rods.ends[:, 0], 0.5 * self.rods.mass)
        np.add.at(m, self.rods.ends[:, 1], 0.5 * self.rods.mass)
        for body in self.bodies:
            m[list(body.nodes)] += body.mass / len(body.nodes)
        out: FloatArray = m
        return out

    def total_mass(self) -> float:
        """Mass of rods, rigid bodies and point masses [kg]."""
        return float(self.rods.mass.sum() + sum(b.mass for b in self.bodies) + self.node_masses.sum())

    def member_EA(self, rest_lengths: ArrayLike | None = None) -> FloatArray:
        """(m,) axial stiffnesses [N] of the statics' members (rods, then cables): rods as bars
        of :data:`ROD_STIFFNESS_RATIO` times the stiffest cable's ``EA / L``, cables as
        strings of ``EA = k l0`` with the cables' ``rest_lengths`` [m] (default: as drawn)."""
        l0 = self.cables.rest_length if rest_lengths is None else np.asarray(rest_lengths, dtype=float)
        rod_EA = ROD_STIFFNESS_RATIO * float(self.cables.stiffness.max()) * self.rod_lengths()
        out: FloatArray = np.concatenate([rod_EA, statics_EA(self.cables.stiffness, l0)])
        return out

    def force_unit(self, rest_lengths: ArrayLike | None = None) -> float:
        """The unit [N] of forces (and stiffnesses, loads) of :meth:`structure` with these
        ``rest_lengths`` (:func:`statics_force_unit`): 1 but for cables stiffer than about
        1e11 N/m."""
        return statics_force_unit(self.member_EA(rest_lengths))

    def structure(self, rest_lengths: ArrayLike | None = None, *, nodes: ArrayLike | None = None,
                  pinned: ArrayLike | None = None, gravity: bool = True) -> Structure:
        """The robot as the statics see it: rods as bars of axial stiffness
        :data:`ROD_STIFFNESS_RATIO` times the stiffest cable's (their mass lumped half at each
        cap, exact for the weight of a symmetric rod), cables as strings of ``EA = k l0``
        with the cables' ``rest_lengths`` [m] (default: as drawn), the robot's bodies,
        supports (or ``pinned`` (n, 3)), point masses and, with ``gravity``, its gravity;
        drawn at ``nodes`` (default: the robot's). Its forces, stiffnesses ``EA`` and
        gravity's loads are in units of :meth:`force_unit` newtons (1 N but for cables
        stiffer than about 1e11 N/m), so that every robot the description accepts is a
        structure the format accepts: multiply its forces by that unit for newtons."""
        l0 = self.cables.rest_length if rest_lengths is None else np.asarray(rest_lengths, dtype=float)
        EA = self.member_EA(l0)
        unit = statics_force_unit(EA)
        return Structure(
            name=self.name, node_names=self.node_names,
            nodes=self.nodes if nodes is None else np.asarray(nodes, dtype=float),
            member_names=self.member_names,
            members=np.vstack([self.rods.ends, self.cables.ends]),
            member_kinds=("bar",) * len(self.rods) + ("string",) * len(self.cables),
            EA=EA / unit, rest_lengths=np.concatenate([self.rod_lengths(), l0]),
            member_masses=np.concatenate([self.rods.mass, np.zeros(len(self.cables))]),
            pinned=self.pinned if pinned is None else np.asarray(pinned, dtype=bool),
            bodies=self.bodies, loads=np.zeros((self.n_nodes, 3)), node_masses=self.node_masses,
            gravity=(self.gravity if gravity else np.zeros(3)) / unit)
