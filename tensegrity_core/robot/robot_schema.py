"""The robot description's schema: parsed data (dict) to a checked :class:`Robot`.

The format (documented in ``docs/structures.md``, "Robots") is the structure format's
nodes, supports, rigid bodies, point masses and gravity, with ``rods`` and ``cables`` in
place of ``members``, and ``cable_defaults``, ``sensors`` and ``floor``. Every value is
checked by :class:`tensegrity_core.schema.Reader` where it is read; a problem raises
:class:`RobotError` with the key path, the line (YAML) and the file, e.g.
``three_bar.yaml: cables[3].motor.range: rest length 0.9 m is outside the motor's range
[0.05, 0.65] m (line 31)``. The nodes, bodies and supports are then built and checked by
the structure's own schema, with the rods and cables as members (:meth:`Robot.structure`
is the same twin with the statics' stiffnesses).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Final

import numpy as np

from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.general.structure_schema import structure_from_dict
from tensegrity_core.robot.contact import floor_normal
from tensegrity_core.robot.description import Cables, Floor, Motors, Robot, RobotError, Rods, Sensors
from tensegrity_core.robot.motor import MODES
from tensegrity_core.robot.rod import rod_inertia
from tensegrity_core.schema import MAX_MAGNITUDE, KeyPath, Reader, described, excerpt, line_of, suggest

TOP_KEYS: Final = ("name", "units", "description", "nodes", "rods", "cables", "cable_defaults", "sensors",
                   "floor", "pinned", "rigid_bodies", "masses", "gravity")
ROD_KEYS: Final = ("name", "nodes", "mass", "radius", "cap_mass", "cap_radius", "inertia")
CABLE_KEYS: Final = ("name", "nodes", "stiffness", "damping", "rest_length", "rest_length_ratio", "motor")
CABLE_DEFAULT_KEYS: Final = ("stiffness", "damping", "rest_length_ratio", "motor")
MOTOR_KEYS: Final = ("range", "tau", "max_speed", "max_tension", "mode")
SENSOR_KEYS: Final = ("cable_length", "cable_tension", "imu")
FLOOR_KEYS: Final = ("normal", "incline", "point", "stiffness", "dissipation", "mu_static", "mu_kinetic",
                     "tangential_stiffness", "tangential_damping", "rolling_friction", "torsional_friction")
#: How far a cap may reach into the floor as drawn [m] (rounding of the drawing).
DRAWN_CONTACT_TOLERANCE: Final = 1e-9
#: The least ratio of a rod's axial to transverse inertia [1]. The dynamics hold a rod's
#: inertia in the drawing's axes and solve with its inverse, which rounds to ``kappa eps``
#: of itself for the condition number ``kappa = I_t / I_a``: at 1e12 its spin about its axis
#: is kept to 1e-4, at 1/eps = 4.5e15 the inverse fails. A capsule has ``I_a / I_t`` about
#: ``6 (r / L)^2``: the bound is a radius of 4e-7 of the rod's length.
MIN_AXIAL_INERTIA_RATIO: Final = 1e-12
#: The least nonzero size a robot takes, of its unit [1]: the reciprocal of the largest
#: number any description takes (:data:`~tensegrity_core.schema.MAX_MAGNITUDE`, 1e15), so
#: that the dynamics' products of sizes and their reciprocals (an acceleration ``k x / m``,
#: a rate ``sqrt(k / m)``, their squares) stay inside double precision: a rod of 1e-300 kg on
#: a cable of 1e9 N/m has a mode past the largest double (the step check asked for a step
#: in (0, 0] s).
MIN_SIZE: Final = 1.0 / MAX_MAGNITUDE
#: The unit of each positive size a robot's description and a robot scene's effects take.
SIZE_UNITS: Final = {"mass": "kg", "radius": "m", "cap_mass": "kg", "cap_radius": "m", "inertia": "kg m^2",
                     "stiffness": "N/m", "damping": "N s/m", "rest_length": "m", "rest_length_ratio": "(a ratio)",
                     "range": "m", "tau": "s", "max_speed": "m/s", "max_tension": "N", "dissipation": "s/m",
                     "mu_static": "(a coefficient)", "mu_kinetic": "(a coefficient)", "tangential_stiffness": "N/m",
                     "tangential_damping": "N s/m", "rolling_friction": "m", "torsional_friction": "m",
                     "masses": "kg"}


def size_reason(x: float, key: str) -> str | None:
    """Why ``x`` is no size of ``key`` (:data:`SIZE_UNITS`): nonzero and below :data:`MIN_SIZE`
    of its unit; None when it is one."""
    if x == 0 or not abs(x) < MIN_SIZE:
        return None
    unit = SIZE_UNITS[key]
    return (f"{x:g} {unit} is below the least nonzero size a robot takes, {MIN_SIZE:g} {unit} (accepted: "
            f"[{MIN_SIZE:g}, {MAX_MAGNITUDE:g}] {unit}, or 0 where the key allows it)")


def robot_from_dict(data: object, *, default_name: str = "robot", file: str | None = None) -> Robot:
    """Check a robot description (parsed data) and build the :class:`Robot`."""
    return _RobotReader(file).robot(data, default_name)


class _RobotReader(Reader):
    def __init__(self, file: str | None):
        super().__init__(RobotError, file)

    def number(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, unit: str | None = None,
               **options: Any) -> float:
        """:meth:`Reader.number` in ``unit`` (by default the key's unit in :data:`SIZE_UNITS`),
        and a size given is 0 or at least :data:`MIN_SIZE` of its unit."""
        if unit is None:
            unit = SIZE_UNITS[key]
        x: float = super().number(d, key, path, unit="" if unit.startswith("(") else unit, **options)
        if key in d and key in SIZE_UNITS:
            self.check_size(x, key, path + (key,), d, key)
        return x

    def check_size(self, x: float, key: str, path: KeyPath, container: Any, at: Any) -> None:
        reason = size_reason(x, key)
        if reason is not None:
            raise self.error(reason, path, container, at)

    # -- the robot -----------------------------------------------------------------------------
    def robot(self, data: object, default_name: str) -> Robot:
        d = self.mapping(data, ())
        self.keys(d, (), TOP_KEYS, required=("nodes", "cables"))
        name = self.string(d, "name", (), default=default_name)
        description = self.string(d, "description", (), default="") if "description" in d else ""
        if "units" in d:
            units = self.string(d, "units", ())
            if units.strip().upper() != "SI":
                raise self.error(f"only SI (m, N, kg, s) is supported, got {excerpt(units)}", ("units",), d, "units")
        names, coords = self.read_nodes(d)
        index = {n: i for i, n in enumerate(names)}
        rods = self.rods(d.get("rods", []), d, index, coords)
        defaults = self.cable_defaults(d)
        cables, motors = self.cables(d["cables"], d, index, coords, defaults)
        self.unique_members(d, rods.names + cables.names)
        twin = self.statics_twin(d, rods, cables)
        self.check_masses(d, names, twin)
        sensors = self.sensors(d, rods, cables, twin.bodies)
        floor = self.floor(d) if "floor" in d else None
        robot = Robot(name=name, node_names=tuple(names), nodes=coords, rods=rods, cables=cables,
                      motors=motors, sensors=sensors, floor=floor, bodies=twin.bodies, pinned=twin.pinned,
                      node_masses=twin.node_masses, gravity=twin.gravity, description=description)
        self.check_axial_inertia(robot, d)
        if floor is not None:
            self.check_above_floor(robot, d)
        return robot

    def read_nodes(self, d: dict[Any, Any]) -> tuple[list[str], np.ndarray]:
        """``nodes``: a mapping ``name: [x, y, z]`` [m]."""
        nodes = self.mapping(d["nodes"], ("nodes",), d, "nodes")
        if len(nodes) < 2:
            raise self.error("must name at least two nodes (name: [x, y, z])", ("nodes",), d, "nodes")
        names: list[str] = []
        rows = []
        for name, xyz in nodes.items():
            if isinstance(name, bool) or not isinstance(name, (str, int)):
                raise self.error(f"a node name must be a string, got {excerpt(name)}", ("nodes",), nodes, name)
            names.append(str(name))
            rows.append(self.vector(xyz, 3, ("nodes", name), nodes, name, unit="m", what="coordinates [x, y, z] (m)"))
        return names, np.array(rows, dtype=float)

    def statics_twin(self, d: dict[Any, Any], rods: Rods, cables: Cables) -> Structure:
        """The robot's supports, bodies, point masses and gravity, read and checked by the
        structure schema together with the rods and cables as its members (rigid bodies,
        supports and members checked against each other: a rod end in a body, a free node
        without a cable, ...)."""
        part = {k: d[k] for k in ("nodes", "pinned", "rigid_bodies", "masses", "gravity") if k in d}
        names = list(d["nodes"])
        members = [{"name": n, "nodes": [names[a], names[b]], "type": "bar", "EA": 1.0}
                   for n, (a, b) in zip(rods.names, rods.ends.tolist())]
        members += [{"name": n, "nodes": [names[a], names[b]], "type": "string", "EA": 1.0, "rest_length": l0}
                    for n, (a, b), l0 in zip(cables.names, cables.ends.tolist(), cables.rest_length.tolist())]
        part["members"] = members
        try:
            return structure_from_dict(part)
        except StructureError as err:
            key, reason = err.key, err.reason
            if key and key[0] == "members" and len(key) > 1 and isinstance(key[1], int):
                key = ("rods", key[1]) if key[1] < len(rods) else ("cables", key[1] - len(rods))
                if reason.startswith("member "):
                    reason = ("rod " if key[0] == "rods" else "cable ") + reason[len("member "):]
            line = err.line
            if line is None and len(key) == 2:
                line = line_of(d.get(str(key[0])), key[1])
            raise RobotError(reason, key=key, line=line, file=self.file) from None

    def check_masses(self, d: dict[Any, Any], names: list[str], twin: Structure) -> None:
        """Point masses and rigid bodies' masses are 0 or at least :data:`MIN_SIZE` kg."""
        for i in np.flatnonzero(twin.node_masses).tolist():
            masses = next(d[k] for k in ("masses", "point_masses") if k in d)
            self.check_size(float(twin.node_masses[i]), "masses", ("masses", names[i]), masses, names[i])
        for j, body in enumerate(twin.bodies):
            bodies = next(d[k] for k in ("rigid_bodies", "bodies") if k in d)
            self.check_size(float(body.mass), "mass", ("rigid_bodies", j, "mass"), bodies[j], "mass")

    def node_pair(self, item: dict[Any, Any], path: KeyPath, index: Mapping[str, int], coords: np.ndarray,
                  what: str) -> tuple[int, int]:
        ends = item.get("nodes")
        if not isinstance(ends, list) or len(ends) != 2:
            raise self.error(f"{what}: nodes must be a pair [a, b] of node names, got {excerpt(ends)}", path + (
                "nodes",), item, "nodes")
        out = []
        for e in ends:
            if not isinstance(e, str) or e not in index:
                raise self.error(f"{what}: unknown node {excerpt(e)}{suggest(e, index)}", path + ("nodes",), item,
                                 "nodes")
            out.append(index[e])
        a, b = out
        if a == b:
            raise self.error(f"{what} joins node {excerpt(ends[0])} to itself", path + ("nodes",), item, "nodes")
        if not np.linalg.norm(coords[b] - coords[a]) > 0:
            raise self.error(f"{what} has zero length: nodes {excerpt(ends[0])} and {excerpt(ends[1])} are both at "
                             f"{coords[a].tolist()}", path + ("nodes",), item, "nodes")
        return a, b

    def entry_name(self, item: dict[Any, Any], path: KeyPath, default: str) -> str:
        if "name" not in item:
            return default
        name = item["name"]
        if isinstance(name, bool) or not isinstance(name, (str, int)):
            raise self.error(f"must be a string, got {excerpt(name)}", path + ("name",), item, "name")
        return str(name)

    # -- rods ------------------------------------------------------------------------------------
    def rods(self, value: object, parent: dict[Any, Any], index: Mapping[str, int], coords: np.ndarray) -> Rods:
        if not isinstance(value, list):
            raise self.error(f"must be a list of rods, got {described(value)}", ("rods",),
                             parent, "rods")
        names: list[str] = []
        ends: list[tuple[int, int]] = []
        rows: list[tuple[float, float, float, float, float]] = []
        used: dict[int, str] = {}
        for i, item in enumerate(value):
            path: KeyPath = ("rods", i)
            r = self.mapping(item, path, value, i)
            self.keys(r, path, ROD_KEYS, required=("nodes", "mass", "radius"))
            name = self.entry_name(r, path, f"rod{i}")
            what = f"rod {excerpt(name)}"
            a, b = self.node_pair(r, path, index, coords, what)
            for node in (a, b):
                if node in used:
                    raise self.error(f"{what}: node {excerpt(list(index)[node])} is already an end of rod "
                                     f"{excerpt(used[node])}; rods do not share end caps", path + ("nodes",), r, "nodes")
                used[node] = name
            L = float(np.linalg.norm(coords[b] - coords[a]))
            mass = self.number(r, "mass", path, lo=0.0, lo_open=True)
            radius = self.number(r, "radius", path, lo=0.0)
            cap_mass = self.number(r, "cap_mass", path, default=0.0, lo=0.0)
            if 2 * cap_mass > mass:
                raise self.error(f"{what}: two caps of {cap_mass:g} kg weigh more than the rod's {mass:g} kg",
                                 path + ("cap_mass",), r, "cap_mass")
            cap_radius = self.number(r, "cap_radius", path, default=radius if radius > 0 else None, lo=0.0,
                                     lo_open=True)
            if "inertia" in r:
                I_t, I_a = self.vector(r["inertia"], 2, path + ("inertia",), r, "inertia",
                                       unit="kg m^2", what="numbers [I_transverse, I_axial] (kg m^2)")
                for j, value in enumerate((I_t, I_a)):
                    self.check_size(value, "inertia", path + ("inertia", j), r["inertia"], j)
                if not (I_t > 0 and I_a > 0 and I_a <= 2 * I_t):
                    raise self.error(f"{what}: inertia [{I_t:g}, {I_a:g}] kg m^2 is not a rod's: both must be > 0 "
                                     f"and I_axial <= 2 I_transverse", path + ("inertia",), r, "inertia")
            else:
                t, ax = rod_inertia(mass - 2 * cap_mass, radius, cap_mass, cap_radius, L)
                I_t, I_a = float(t), float(ax)
                if not I_a > 0:
                    raise self.error(f"{what} has no inertia about its axis: give it a radius > 0, end caps with "
                                     f"cap_mass and cap_radius, or its inertia", path, value, i)
            names.append(name)
            ends.append((a, b))
            rows.append((mass, radius, cap_radius, I_t, I_a))
        arr = np.array(rows, dtype=float).reshape(-1, 5)
        return Rods(tuple(names), np.array(ends, dtype=np.int64).reshape(-1, 2), arr[:, 0], arr[:, 1], arr[:, 2],
                    arr[:, 3:5])

    # -- cables ----------------------------------------------------------------------------------
    def cable_defaults(self, d: dict[Any, Any]) -> dict[str, Any]:
        if "cable_defaults" not in d:
            return {}
        path: KeyPath = ("cable_defaults",)
        c = self.mapping(d["cable_defaults"], path, d, "cable_defaults")
        self.keys(c, path, CABLE_DEFAULT_KEYS)
        out: dict[str, Any] = {}
        if "stiffness" in c:
            out["stiffness"] = self.number(c, "stiffness", path, lo=0.0, lo_open=True)
        if "damping" in c:
            out["damping"] = self.number(c, "damping", path, lo=0.0)
        if "rest_length_ratio" in c:
            out["rest_length_ratio"] = self.number(c, "rest_length_ratio", path, lo=0.0, lo_open=True)
        if "motor" in c:
            m = self.mapping(c["motor"], path + ("motor",), c, "motor")
            self.keys(m, path + ("motor",), MOTOR_KEYS)
            out["motor"] = (m, path + ("motor",))
        return out

    def cables(self, value: object, parent: dict[Any, Any], index: Mapping[str, int], coords: np.ndarray,
               defaults: dict[str, Any]) -> tuple[Cables, Motors]:
        if not isinstance(value, list) or not value:
            raise self.error(f"must be a non-empty list of cables, got {described(value)}",
                             ("cables",), parent, "cables")
        names: list[str] = []
        ends: list[tuple[int, int]] = []
        rows: list[tuple[float, float, float]] = []
        motor_of: list[int] = []
        motors: list[tuple[int, float, float, float, float, float]] = []
        modes: list[int] = []
        for i, item in enumerate(value):
            path: KeyPath = ("cables", i)
            c = self.mapping(item, path, value, i)
            self.keys(c, path, CABLE_KEYS, required=("nodes",))
            name = self.entry_name(c, path, f"cable{i}")
            what = f"cable {excerpt(name)}"
            a, b = self.node_pair(c, path, index, coords, what)
            k = self.number(c, "stiffness", path, lo=0.0, lo_open=True) if "stiffness" in c else \
                self.default(defaults, "stiffness", c, path, what)
            damping = self.number(c, "damping", path, lo=0.0) if "damping" in c else defaults.get("damping", 0.0)
            drawn = float(np.linalg.norm(coords[b] - coords[a]))
            if "rest_length" in c and "rest_length_ratio" in c:
                raise self.error(f"{what}: give rest_length or rest_length_ratio, not both", path, value, i)
            if "rest_length" in c:
                l0 = self.number(c, "rest_length", path, lo=0.0, lo_open=True)
            else:
                ratio = self.number(c, "rest_length_ratio", path, lo=0.0, lo_open=True) if "rest_length_ratio" in c \
                    else defaults.get("rest_length_ratio", 1.0)
                l0 = ratio * drawn
            if "motor" in c:
                lo, hi, tau, speed, t_max, mode = self.motor(c, path, defaults.get("motor"), what)
                if not lo <= l0 <= hi:
                    where = "rest_length" if "rest_length" in c else "rest_length_ratio" if "rest_length_ratio" in c \
                        else "motor"
                    raise self.error(f"{what}: rest length {l0:g} m is outside the motor's range [{lo:g}, {hi:g}] m",
                                     path + (where,), c, where)
                motors.append((i, lo, hi, tau, speed, t_max))
                modes.append(mode)
                motor_of.append(len(motors) - 1)
            else:
                motor_of.append(-1)
            names.append(name)
            ends.append((a, b))
            rows.append((k, damping, l0))
        arr = np.array(rows, dtype=float)
        m = np.array([row[1:] for row in motors], dtype=float).reshape(-1, 5)
        return (Cables(tuple(names), np.array(ends, dtype=np.int64), arr[:, 0], arr[:, 1], arr[:, 2],
                       np.array(motor_of, dtype=np.int64)),
                Motors(np.array([row[0] for row in motors], dtype=np.int64), m[:, 0:2], m[:, 2], m[:, 3], m[:, 4],
                       np.array(modes, dtype=np.int64)))

    def default(self, defaults: dict[str, Any], key: str, item: dict[Any, Any], path: KeyPath, what: str) -> float:
        if key not in defaults:
            raise self.error(f"{what}: missing {key!r} (in the cable or in cable_defaults)", path, item, None)
        value: float = defaults[key]
        return value

    def motor(self, c: dict[Any, Any], path: KeyPath, defaults: tuple[dict[Any, Any], KeyPath] | None,
              what: str) -> tuple[float, float, float, float, float, int]:
        """``(lo, hi, tau, max_speed, max_tension, mode)`` of a cable's ``motor`` (a mapping,
        or ``true`` for the defaults' motor); ``mode`` one of :data:`.motor.MODES`' values."""
        raw = c["motor"]
        mpath = path + ("motor",)
        if raw is True:
            if defaults is None:
                raise self.error(f"{what}: motor: true needs a motor in cable_defaults", mpath, c, "motor")
            raw = {}
        m = self.mapping(raw, mpath, c, "motor")
        self.keys(m, mpath, MOTOR_KEYS)
        base, bpath = defaults if defaults is not None else ({}, mpath)

        def pick(key: str) -> tuple[dict[Any, Any], KeyPath]:
            return (m, mpath) if key in m else (base, bpath)

        src, spath = pick("range")
        if "range" not in src:
            raise self.error(f"{what}: a motor needs its rest-length range [lo, hi] (m)", mpath, c, "motor")
        lo, hi = self.vector(src["range"], 2, spath + ("range",), src, "range", unit="m", what="rest lengths [lo, hi] (m)")
        for j, value in enumerate((lo, hi)):
            self.check_size(value, "range", spath + ("range", j), src["range"], j)
        if not 0 < lo < hi:
            raise self.error(f"{what}: the range must be 0 < lo < hi, got [{lo:g}, {hi:g}] m", spath + ("range",),
                             src, "range")
        src, spath = pick("tau")
        tau = self.number(src, "tau", spath, default=0.0, lo=0.0)
        src, spath = pick("max_speed")
        speed = self.number(src, "max_speed", spath, default=math.inf, lo=0.0, lo_open=True, allow_inf=True)
        src, spath = pick("max_tension")
        t_max = self.number(src, "max_tension", spath, default=math.inf, lo=0.0, lo_open=True, allow_inf=True)
        src, spath = pick("mode")
        mode = self.string(src, "mode", spath, default="rest_length", choices=tuple(MODES))
        return lo, hi, tau, speed, t_max, MODES[mode]

    def unique_members(self, d: dict[Any, Any], names: tuple[str, ...]) -> None:
        seen: dict[str, str] = {}
        for kind, start in (("rods", 0), ("cables", len(d.get("rods", [])))):
            for i in range(len(d.get(kind, []))):
                name = names[start + i]
                if name in seen:
                    raise self.error(f"name {excerpt(name)} is used twice ({seen[name]} and {kind}[{i}]); rods and "
                                     f"cables need distinct names", (kind, i), d[kind], i)
                seen[name] = f"{kind}[{i}]"

    # -- sensors ----------------------------------------------------------------------------------
    def sensors(self, d: dict[Any, Any], rods: Rods, cables: Cables, bodies: tuple[Any, ...]) -> Sensors:
        every = tuple(range(len(cables)))
        if "sensors" not in d:
            return Sensors(cable_length=every, cable_tension=every)
        path: KeyPath = ("sensors",)
        s = self.mapping(d["sensors"], path, d, "sensors")
        self.keys(s, path, SENSOR_KEYS)
        length = self.selection(s, "cable_length", path, cables.names, "cable", every)
        tension = self.selection(s, "cable_tension", path, cables.names, "cable", every)
        carriers = rods.names + tuple(b.name for b in bodies)
        imu = self.selection(s, "imu", path, carriers, "rod or rigid body", ())
        n_rods = len(rods)
        return Sensors(cable_length=length, cable_tension=tension, imu_rods=tuple(i for i in imu if i < n_rods),
                       imu_bodies=tuple(i - n_rods for i in imu if i >= n_rods))

    def selection(self, s: dict[Any, Any], key: str, path: KeyPath, names: tuple[str, ...], what: str,
                  default: tuple[int, ...]) -> tuple[int, ...]:
        """``all``, ``none`` or a list of names -> indices."""
        if key not in s:
            return default
        value = s[key]
        if value == "all":
            return tuple(range(len(names)))
        if value == "none" or value == []:
            return ()
        if not isinstance(value, list):
            raise self.error(f"must be all, none or a list of {what} names, got {excerpt(value)}", path + (key,), s,
                             key)
        out = []
        for j, name in enumerate(value):
            if not isinstance(name, str) or name not in names:
                raise self.error(f"unknown {what} {excerpt(name)}{suggest(name, names)}", path + (key, j), value, j)
            if names.index(name) in out:
                raise self.error(f"{what} {excerpt(name)} is listed twice", path + (key, j), value, j)
            out.append(names.index(name))
        return tuple(out)

    # -- floor --------------------------------------------------------------------------------------
    def floor(self, d: dict[Any, Any]) -> Floor:
        path: KeyPath = ("floor",)
        f = self.mapping(d["floor"], path, d, "floor")
        self.keys(f, path, FLOOR_KEYS, required=("stiffness", "mu_static"))
        if "normal" in f and "incline" in f:
            raise self.error("give normal or incline, not both", path, d, "floor")
        if "incline" in f:
            inc = self.mapping(f["incline"], path + ("incline",), f, "incline")
            self.keys(inc, path + ("incline",), ("angle", "heading"), required=("angle",))
            angle = self.number(inc, "angle", path + ("incline",), unit="deg", lo=0.0, hi=90.0, hi_open=True)
            heading = self.number(inc, "heading", path + ("incline",), unit="deg", default=0.0)
            normal = floor_normal(math.radians(angle), math.radians(heading))
        elif "normal" in f:
            v = np.array(self.vector(f["normal"], 3, path + ("normal",), f, "normal", unit=""))
            size = float(np.linalg.norm(v))
            if not size > 0:
                raise self.error("the normal must not be the zero vector", path + ("normal",), f, "normal")
            normal = v / size
        else:
            normal = np.array([0.0, 0.0, 1.0])
        point = np.array(self.vector(f["point"], 3, path + ("point",), f, "point", unit="m")) if "point" in f else np.zeros(3)
        k = self.number(f, "stiffness", path, lo=0.0, lo_open=True)
        mu_s = self.number(f, "mu_static", path, lo=0.0)
        mu_k = self.number(f, "mu_kinetic", path, default=mu_s, lo=0.0)
        if mu_k > mu_s:
            raise self.error(f"kinetic friction {mu_k:g} exceeds static friction {mu_s:g}", path + ("mu_kinetic",), f,
                             "mu_kinetic")
        return Floor(normal=normal, point=point, stiffness=k,
                     dissipation=self.number(f, "dissipation", path, default=0.0, lo=0.0),
                     mu_static=mu_s, mu_kinetic=mu_k,
                     tangential_stiffness=self.number(f, "tangential_stiffness", path, default=k, lo=0.0, lo_open=True),
                     tangential_damping=self.number(f, "tangential_damping", path, default=0.0, lo=0.0),
                     rolling_friction=self.number(f, "rolling_friction", path, default=0.0, lo=0.0),
                     torsional_friction=self.number(f, "torsional_friction", path, default=0.0, lo=0.0))

    # -- whole-robot checks ---------------------------------------------------------------------------
    def check_axial_inertia(self, robot: Robot, d: dict[Any, Any]) -> None:
        """Each rod's axial inertia is at least :data:`MIN_AXIAL_INERTIA_RATIO` of its
        transverse inertia, counting the point masses on its caps (``m (L/2)^2`` each, an upper
        bound about the rod's centre of mass)."""
        rods = robot.rods
        lengths = np.linalg.norm(robot.nodes[rods.ends[:, 1]] - robot.nodes[rods.ends[:, 0]], axis=1)
        riders = robot.node_masses[rods.ends].sum(axis=1)
        I_t = rods.inertia[:, 0] + riders * (lengths / 2) ** 2
        I_a = rods.inertia[:, 1]
        bad = np.flatnonzero(~(I_a >= MIN_AXIAL_INERTIA_RATIO * I_t))
        if len(bad):
            j = int(bad[0])
            key = "inertia" if "inertia" in d["rods"][j] else "cap_radius" if "cap_radius" in d["rods"][j] else "radius"
            raise self.error(f"rod {excerpt(rods.names[j])}: its axial inertia {I_a[j]:.3g} kg m^2 is below "
                             f"{MIN_AXIAL_INERTIA_RATIO:g} of its transverse inertia {I_t[j]:.3g} kg m^2 (with the "
                             f"point masses on its caps), which double precision cannot carry beside it: give it a "
                             f"thicker radius or cap_radius (a capsule's ratio is about 6 (radius / length)^2), "
                             f"or its inertia [I_t, I_a] with I_a >= {MIN_AXIAL_INERTIA_RATIO:g} I_t",
                             ("rods", j, key), d["rods"][j], key)

    def check_above_floor(self, robot: Robot, d: dict[Any, Any]) -> None:
        """No end cap may start inside the floor."""
        assert robot.floor is not None
        ends = robot.rods.ends
        radius = np.repeat(robot.rods.cap_radius, 2)
        caps = ends.reshape(-1)
        depth = radius - robot.floor.heights(robot.nodes[caps])
        worst = int(np.argmax(depth)) if len(caps) else -1
        if worst >= 0 and depth[worst] > DRAWN_CONTACT_TOLERANCE:
            rod = worst // 2
            node = robot.node_names[caps[worst]]
            raise self.error(f"cap {excerpt(node)} of rod {excerpt(robot.rods.names[rod])} starts {depth[worst]:.4g} m "
                             f"inside the floor (its centre {radius[worst] - depth[worst]:.4g} m above it, radius "
                             f"{radius[worst]:.4g} m); draw the robot higher or move the floor down",
                             ("rods", rod), d.get("rods"), rod)
