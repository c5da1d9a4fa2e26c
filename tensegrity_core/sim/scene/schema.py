"""The scene's schema: parsed data to a checked, frozen :class:`~tensegrity_core.sim.scene.spec.Scene`.

:class:`SceneReader` checks each section of a scene (model, effects, initial state, inputs,
output, integrator) with the shared checks of :class:`tensegrity_core.schema.Reader`; a
robot model's parts are :mod:`.robot_schema`'s. Every problem raises
:class:`~tensegrity_core.sim.errors.SceneError` naming the key path and, for YAML, the line:
unknown keys (with a suggestion), missing required keys, wrong types, impossible values
(negative durations, restitution above 1, initial states outside the mechanism's domain,
unknown node names), effect combinations that cannot mean anything (damping without
inertia, the fold limit on a general structure) and output that would not fit in memory
(``duration`` times ``output.rate`` samples). The entry points are :mod:`.reader`'s.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar, cast

import numpy as np

from tensegrity_core.class2.dynamics.limits import SINGULAR_GUARD_REL
from tensegrity_core.class2.names import ACTUATORS
from tensegrity_core.errors import TensegrityError
from tensegrity_core.general.structure import STANDARD_GRAVITY, Structure
from tensegrity_core.robot.gait import read_gait
from tensegrity_core.schema import (
    KeyPath,
    Reader,
    described,
    excerpt,
    suggest,
    type_name,
)
from tensegrity_core.sim.errors import SceneError
from tensegrity_core.sim.inputs import Commanded, Constant, InputLaw, Proportional, Ramp
from tensegrity_core.sim.scene.references import structure_source
from tensegrity_core.sim.scene.robot_schema import (
    control_rate_fits,
    robot_control,
    robot_effect,
    robot_model,
    step_fits,
    within_motor_ranges,
)
from tensegrity_core.sim.scene.series import read_series
from tensegrity_core.sim.scene.spec import (
    EFFECTS,
    METHODS,
    NEEDS_INERTIA,
    NOISE_UNITS,
    NOISY_QUANTITIES,
    ROBOT_EFFECTS,
    ActuatorComplianceSpec,
    ActuatorLagSpec,
    Class2ModelSpec,
    DampingSpec,
    EffectSpec,
    FlagSpec,
    FoldLimitSpec,
    GeneralModelSpec,
    GravitySpec,
    InitialSpec,
    IntegratorSpec,
    LoadsSpec,
    ModelSpec,
    RobotModelSpec,
    Scene,
    SceneEffects,
    SensorNoiseSpec,
    output_size_reason,
)

#: The fixed step of a robot scene without ``integrator.max_step`` [s] (a 1 kHz loop).
ROBOT_STEP = 1.0e-3
#: Effects that only robots have.
ROBOT_ONLY = tuple(e for e in ROBOT_EFFECTS if e not in ("inertia", "gravity"))

class SceneReader(Reader):
    """The scene's schema over the shared checks; ``base`` is the folder of relative paths."""

    def __init__(self, file: str | None, base: Path, source: str | None = None):
        super().__init__(SceneError, file)
        self.base = base
        self.source = source

    # -- the scene -----------------------------------------------------------------------
    TOP = ("name", "description", "model", "initial", "inputs", "control", "effects", "output", "duration",
           "integrator", "seed")

    def scene(self, data: object) -> Scene:
        d = self.mapping(data, ())
        self.keys(d, (), self.TOP, required=("model", "initial", "effects", "duration"))
        name = self.string(d, "name", (), default=Path(self.file).stem if self.file else "scene")
        description = self.string(d, "description", (), default="") if "description" in d else ""
        model = self.model(d["model"], ("model",), d)
        effects = self.effects(d["effects"], ("effects",), d, model)
        initial = self.initial(d["initial"], ("initial",), d, model, effects)
        inputs = self.inputs(d.get("inputs"), ("inputs",), d, model, effects)
        control = robot_control(self, d, model) if "control" in d else None
        duration = self.number(d, "duration", (), unit="s", lo=0.0, lo_open=True)
        output_rate = 100.0
        if "output" in d:
            out = self.mapping(d["output"], ("output",), d, "output")
            self.keys(out, ("output",), ("rate",), required=("rate",))
            output_rate = self.number(out, "rate", ("output",), unit="Hz", lo=0.0, lo_open=True)
        reason = output_size_reason(duration, output_rate, model)
        if reason:
            where = ("output", "rate") if "output" in d else ("duration",)
            raise self.error(reason, where, d["output"] if "output" in d else d, where[-1])
        integrator = self.integrator(d.get("integrator"), ("integrator",), d, model)
        if isinstance(model, RobotModelSpec):
            step_fits(self, model, effects, integrator.max_step, d, getattr(initial, "lift", 0.0))
        if control is not None:
            control_rate_fits(self, control, integrator.max_step, d)
        seed = self.integer(d, "seed", (), default=0, lo=0)
        return Scene(name=name, model=model, initial=initial, inputs=inputs, effects=effects,
                     duration=duration, output_rate=output_rate, integrator=integrator, seed=seed,
                     description=description, control=control, source=self.source, data=_plain(d))

    # -- model ---------------------------------------------------------------------------
    def model(self, value: object, path: KeyPath, parent: dict[str, Any]) -> ModelSpec:
        d = self.mapping(value, path, parent, "model")
        kind = self.string(d, "kind", path, choices=("class2", "general", "robot"))
        if kind == "robot":
            return robot_model(self, d, path, self.base)
        if kind == "class2":
            self.keys(d, path, ("kind", "params"))
            from tensegrity_core.class2.params import PAPER_PARAMS, PARAM_UNITS

            overrides: dict[str, float] = {}
            if "params" in d:
                p = self.mapping(d["params"], path + ("params",), d, "params")
                allowed = tuple(PAPER_PARAMS.as_dict()) + ("k", "c")
                self.keys(p, path + ("params",), allowed)
                for k in p:   # dampings c, c1..c4 may be 0; lengths, stiffnesses and the mass may not
                    overrides[k] = self.number(p, k, path + ("params",), unit=PARAM_UNITS[k], lo=0.0, lo_open=not k.startswith("c"))
            try:
                params = PAPER_PARAMS.with_overrides(overrides)
            except TensegrityError as err:
                raise self.error(str(err), path + ("params",), d, "params") from None
            return Class2ModelSpec(params)
        self.keys(d, path, ("kind", "structure", "end_effector"), required=("structure",))
        structure, source = self.structure(d["structure"], path + ("structure",), d)
        if "end_effector" in d:
            ee = self.string(d, "end_effector", path)
            if ee not in structure.node_names:
                raise self.error(f"unknown node {excerpt(ee)}{suggest(ee, structure.node_names)}",
                                 path + ("end_effector",), d, "end_effector")
            end_effector = structure.node_names.index(ee)
        else:
            end_effector = int(structure.n_nodes - 1)
        actuators = tuple(i for i, k in enumerate(structure.member_kinds) if k == "actuator")
        return GeneralModelSpec(structure, source, end_effector, actuators)

    def structure(self, value: object, path: KeyPath, parent: dict[str, Any]) -> tuple[Structure, str]:
        from tensegrity_core.general import StructureError, load_example, structure_from_dict, structure_from_file

        if not isinstance(value, (dict, str)):
            raise self.error(f"must be a shipped example name, a file path or a mapping, got "
                             f"{type_name(value)}", path, parent, "structure")
        try:
            source = structure_source(value, self.base)
        except SceneError as err:
            raise self.error(err.reason, path, parent, "structure") from None
        try:
            if source.data is not None:
                return structure_from_dict(source.data), "inline"
            assert source.path is not None              # a mapping or a file, as structure_source says
            if source.shipped is not None:
                return load_example(source.path.stem), source.path.stem
            return structure_from_file(source.path), str(source.path)
        except StructureError as err:
            raise self.error(f"invalid structure: {err}", path, parent, "structure") from None

    # -- effects ---------------------------------------------------------------------------
    def effects(self, value: object, path: KeyPath, parent: dict[str, Any], model: ModelSpec) -> SceneEffects:
        if not isinstance(value, list):
            raise self.error(f"must be a list of effects, got {described(value)}", path, parent,
                             "effects")
        out: dict[str, EffectSpec] = {}
        for i, item in enumerate(value):
            p = path + (i,)
            options: object
            holder: object
            if isinstance(item, str):
                name, options, opath, holder = item, {}, p, value
            elif isinstance(item, dict) and len(item) == 1:
                name = next(iter(item))
                options = item[name] if item[name] is not None else {}
                opath, holder = p + (name,), item
            else:
                raise self.error(f"each effect is a name or a one-key mapping {{name: {{options}}}}, got "
                                 f"{excerpt(item)}", p, value, i)
            if name not in EFFECTS:
                raise self.error(f"unknown effect {excerpt(name)}{suggest(name, EFFECTS)}; effects: "
                                 f"{', '.join(EFFECTS)}", p, value, i)
            if name in out:
                raise self.error(f"effect {name!r} is listed twice", p, value, i)
            if model.kind == "robot" and name not in ROBOT_EFFECTS:
                raise self.error(f"effect {name!r} does not apply to robots; robot effects: {', '.join(ROBOT_EFFECTS)}",
                                 p, value, i)
            if model.kind != "robot" and name in ROBOT_ONLY:
                raise self.error(f"effect {name!r} applies to robot scenes only (model kind 'robot')", p, value, i)
            options = self.mapping(options, opath, holder, name if holder is item else i)
            out[name] = self.effect_options(name, options, opath, model)
        if "inertia" not in out:
            for name in NEEDS_INERTIA:
                if name in out:
                    i = list(out).index(name)
                    raise self.error(f"effect {name!r} needs 'inertia' (without it the model is quasi-static: "
                                     f"{NEEDS_INERTIA[name]})", path + (i,), value, i)
        if model.kind == "general":
            for name in ("fold_limit", "actuator_compliance", "actuator_lag"):
                if name in out:
                    i = list(out).index(name)
                    raise self.error(f"effect {name!r} applies to the class-2 mechanism only", path + (i,), value, i)
        if model.kind == "robot":
            for needed, why in (("inertia", "robots are simulated with their dynamics"),
                                ("cables", "nothing else holds the rods together")):
                if needed not in out:
                    raise self.error(f"a robot scene needs {needed!r} ({why})", path, parent, "effects")
            if "friction" in out and "contact" not in out:
                i = list(out).index("friction")
                raise self.error("effect 'friction' needs 'contact' (friction acts where the caps touch the floor)",
                                 path + (i,), value, i)
        if "springs" not in out and "inertia" not in out:
            raise self.error("a scene without inertia (quasi-static) needs 'springs': nothing else holds the "
                             "configuration in equilibrium", path, parent, "effects")
        # Order of composition is fixed, not the order of the list; every name is one of EFFECTS
        # with the options effect_options gives it, so the dict is the TypedDict.
        return cast(SceneEffects, {name: out[name] for name in EFFECTS if name in out})

    def effect_options(self, name: str, d: dict[str, Any], path: KeyPath, model: ModelSpec) -> EffectSpec:
        if name in ("motors", "contact", "friction") and isinstance(model, RobotModelSpec):
            return robot_effect(self, name, d, path, model)
        if name in ("inertia", "springs", "cables", "sensors"):
            self.keys(d, path, ())
            return FlagSpec()
        if name == "damping":
            if model.kind == "class2":
                self.keys(d, path, ())
                return DampingSpec()
            self.keys(d, path, ("c", "beta"))
            if ("c" in d) == ("beta" in d):
                raise self.error("give exactly one of 'c' [N s/m] (every member) or 'beta' [s] (c_i = beta EA_i/l0_i)",
                                 path, d, None)
            if "c" in d:
                return DampingSpec(c=self.number(d, "c", path, unit="N s/m", lo=0.0))
            return DampingSpec(beta=self.number(d, "beta", path, unit="s", lo=0.0))
        if name == "gravity":
            self.keys(d, path, ("vector",))
            if "vector" in d:
                return GravitySpec(self.vector(d["vector"], 3, path + ("vector",), d, "vector", unit="m/s^2"))
            if model.kind == "general" and np.any(model.structure.gravity != 0):
                return GravitySpec(tuple(float(g) for g in model.structure.gravity))
            if model.kind == "robot" and np.any(model.robot.gravity != 0):
                return GravitySpec(tuple(float(g) for g in model.robot.gravity))
            return GravitySpec((0.0, 0.0, -STANDARD_GRAVITY))
        if name == "loads":
            names = _node_names(model)
            forces: dict[int, tuple[float, ...]] = {}
            for node, vec in d.items():
                if node not in names:
                    raise self.error(f"unknown node {excerpt(node)}{suggest(node, names)}; nodes: "
                                     f"{', '.join(names[:40])}", path + (node,), d, node)
                forces[names.index(node)] = self.vector(vec, 3, path + (node,), d, node, unit="N")
            if not forces:
                raise self.error("lists no node: give node: [fx, fy, fz] [N]", path, d, None)
            return LoadsSpec(forces)
        if name == "actuator_lag":
            self.keys(d, path, ("tau",), required=("tau",))
            return ActuatorLagSpec(self.number(d, "tau", path, unit="s", lo=0.0, lo_open=True))
        if name == "actuator_compliance":
            self.keys(d, path, ("stiffness", "drive_damping"), required=("drive_damping",))
            # (a general scene has no actuator stiffness to default to: effects() refuses the effect)
            default = model.params.ka if model.kind == "class2" else math.nan
            stiffness = self.number(d, "stiffness", path, unit="N/m", default=default, lo=0.0, lo_open=True)
            return ActuatorComplianceSpec(stiffness, self.number(d, "drive_damping", path, unit="N s/m", lo=0.0, lo_open=True))
        if name == "fold_limit":
            self.keys(d, path, ("restitution", "rest_velocity"))
            return FoldLimitSpec(self.number(d, "restitution", path, unit="", default=0.0, lo=0.0, hi=1.0),
                             self.number(d, "rest_velocity", path, unit="m/s", default=1e-6, lo=0.0, lo_open=True))
        # sensor_noise
        self.keys(d, path, NOISY_QUANTITIES)
        if not d:
            raise self.error(f"lists no quantity; give sigma for some of {', '.join(NOISY_QUANTITIES)}", path, d, None)
        return SensorNoiseSpec({k: self.number(d, k, path, unit=NOISE_UNITS[k], lo=0.0) for k in d})

    # -- initial state -----------------------------------------------------------------------
    def initial(self, value: object, path: KeyPath, parent: dict[str, Any], model: ModelSpec,
                effects: SceneEffects) -> InitialSpec:
        d = self.mapping(value, path, parent, "initial")
        if model.kind == "class2":
            self.keys(d, path, ("q", "qdot", "equilibrium"))
            if ("q" in d) == ("equilibrium" in d):
                raise self.error("give exactly one of 'q: [rho1, rho2, beta]' or 'equilibrium: {rho1, rho2}'",
                                 path, d, None)
            qdot = self.vector(d["qdot"], 3, path + ("qdot",), d, "qdot", unit=("m/s", "m/s", "rad/s")) if "qdot" in d else (0.0, 0.0, 0.0)
            if "q" in d:
                q = self.vector(d["q"], 3, path + ("q",), d, "q", unit=("m", "m", "rad"))
                self.class2_domain(q[0], q[1], model, effects, path + ("q",), d, "q")
                return InitialSpec("state", q=q, qdot=qdot)
            if "qdot" in d:
                raise self.error("'qdot' goes with 'q'; an equilibrium starts at rest", path + ("qdot",), d, "qdot")
            e = self.mapping(d["equilibrium"], path + ("equilibrium",), d, "equilibrium")
            self.keys(e, path + ("equilibrium",), ("rho1", "rho2"), required=("rho1", "rho2"))
            r1 = self.number(e, "rho1", path + ("equilibrium",), unit="m")
            r2 = self.number(e, "rho2", path + ("equilibrium",), unit="m")
            self.class2_domain(r1, r2, model, effects, path + ("equilibrium",), d, "equilibrium")
            return InitialSpec("equilibrium", lengths=(r1, r2))
        if model.kind == "robot":
            self.keys(d, path, ("drawn", "lift"), required=("drawn",))
            if d["drawn"] is not True:
                raise self.error(f"must be true, got {excerpt(d['drawn'])}", path + ("drawn",), d, "drawn")
            return InitialSpec("drawn", lift=self.number(d, "lift", path, unit="m", default=0.0, lo=0.0))
        self.keys(d, path, ("equilibrium", "drawn"))
        if len(d) != 1:
            raise self.error("give exactly one of 'equilibrium: true | {preload: {node: [fx, fy, fz]}}' or "
                             "'drawn: true'", path, d, None)
        if "drawn" in d:
            if d["drawn"] is not True:
                raise self.error(f"must be true, got {excerpt(d['drawn'])}", path + ("drawn",), d, "drawn")
            return InitialSpec("drawn")
        e = d["equilibrium"]
        if e is True:
            return InitialSpec("equilibrium")
        e = self.mapping(e, path + ("equilibrium",), d, "equilibrium")
        self.keys(e, path + ("equilibrium",), ("preload",))
        preload: dict[int, tuple[float, ...]] = {}
        if "preload" in e:
            pl = self.mapping(e["preload"], path + ("equilibrium", "preload"), e, "preload")
            names = model.structure.node_names
            for node, vec in pl.items():
                p = path + ("equilibrium", "preload", node)
                if node not in names:
                    raise self.error(f"unknown node {excerpt(node)}{suggest(node, names)}", p, pl, node)
                preload[names.index(node)] = self.vector(vec, 3, p, pl, node, unit="N")
        return InitialSpec("equilibrium", preload=preload)

    def class2_domain(self, r1: float, r2: float, model: Class2ModelSpec, effects: SceneEffects, path: KeyPath,
                      container: dict[str, Any], key: str) -> None:
        L = model.params.L
        if "fold_limit" in effects and min(r1, r2) < 0:
            raise self.error(f"actuator lengths must be >= 0 with the fold limit, got rho1 = {r1:g}, rho2 = {r2:g}",
                             path, container, key)
        lam1_sq = (2 * L - (r1 + r2)) * (2 * L + (r1 + r2))
        lam2_sq = (L - r1) * (L + r1)
        limit = (SINGULAR_GUARD_REL * L) ** 2
        if lam1_sq <= limit:
            raise self.error(f"|rho1 + rho2| = {abs(r1 + r2):g} m must be below 2L = {2 * L:g} m (struts AE and CE "
                             f"meet at E only then; the coordinates are singular at 2L)", path, container, key)
        if lam2_sq <= limit:
            raise self.error(f"|rho1| = {abs(r1):g} m must be below L = {L:g} m (node F reaches the Y axis only "
                             f"then; the coordinates are singular at L)", path, container, key)

    # -- inputs ----------------------------------------------------------------------------------
    def inputs(self, value: object, path: KeyPath, parent: dict[str, Any], model: ModelSpec,
               effects: SceneEffects) -> dict[str, InputLaw]:
        names: tuple[str, ...]
        if model.kind == "class2":
            names = ACTUATORS
        elif model.kind == "robot":
            names = tuple(model.robot.cables.names[i] for i in model.actuators)
        else:
            names = tuple(model.structure.member_names[i] for i in model.actuators)
        if value is None:
            if model.kind == "robot":          # every motor commanded, holding its drawn rest length
                return {n: Commanded(None) for n in names}
            if names:
                raise self.error(f"missing required key 'inputs' (one law per actuator: {', '.join(names)})",
                                 (), parent, None)
            return {}
        d = self.mapping(value, path, parent, "inputs")
        from_gait: dict[str, InputLaw] = {}
        takes_gait = model.kind in ("general", "robot")
        if takes_gait and "gait" in d:
            gait = read_gait(self, d["gait"], path + ("gait",), d, "gait", self.base)
            for cable in gait.cables:
                if cable not in names:
                    raise self.error(f"the gait drives {excerpt(cable)}, which is not an actuator"
                                     f"{suggest(cable, names)}; actuators: {', '.join(names)}", path + ("gait",), d,
                                     "gait")
                if cable in d:
                    raise self.error(f"actuator {excerpt(cable)} has a law and is driven by the gait; give one",
                                     path + (cable,), d, cable)
            from_gait = dict(gait.laws())
        own = tuple(n for n in names if n not in from_gait)
        robot = model.kind == "robot"           # a robot's motors not listed are commanded, holding their rest length
        self.keys(d, path, names + (("gait",) if takes_gait else ()), required=() if robot else own)
        laws = {n: from_gait[n] if n in from_gait else self.law(d[n], path + (n,), d, n, model) if n in d
                else Commanded(None) for n in names}
        if isinstance(model, RobotModelSpec):
            within_motor_ranges(self, laws, model, path, d, effects.get("motors"))
        return laws

    LAW_KEYS: ClassVar[dict[str, tuple[str, ...]]] = {
        "constant": ("law", "value"), "ramp": ("law", "from", "to", "t0", "t1"), "proportional": ("law", "gain"),
        "series": ("law", "file", "time", "column", "interpolation"), "commanded": ("law", "initial")}

    def law(self, value: object, path: KeyPath, parent: dict[str, Any], key: str, model: ModelSpec) -> InputLaw:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return Constant(self.value_number(value, path, parent, key, unit=model.input_unit))
        d = self.mapping(value, path, parent, key)
        law = self.string(d, "law", path, choices=tuple(self.LAW_KEYS))
        self.keys(d, path, self.LAW_KEYS[law])
        if law == "constant":
            return Constant(self.number(d, "value", path, unit=model.input_unit))
        if law == "ramp":
            t0 = self.number(d, "t0", path, unit="s", default=0.0, lo=0.0)
            t1 = self.number(d, "t1", path, unit="s")
            if t1 <= t0:
                raise self.error(f"must be after t0 = {t0:g} s, got {t1:g}", path + ("t1",), d, "t1")
            return Ramp(self.number(d, "from", path, unit=model.input_unit),
                        self.number(d, "to", path, unit=model.input_unit), t0, t1)
        if law == "proportional":
            if model.kind != "class2":
                raise self.error("law 'proportional' (gain * length * t) is a force law of the class-2 mechanism; "
                                 "general structures take rest lengths", path + ("law",), d, "law")
            return Proportional(self.number(d, "gain", path, unit="N/(m s)"))
        if law == "commanded":
            if "initial" not in d or d["initial"] == "hold":
                return Commanded(None)
            if isinstance(d["initial"], str):
                raise self.error(f"must be a number or 'hold', got {excerpt(d['initial'])}"
                                 f"{suggest(d['initial'], ['hold'])}", path + ("initial",), d, "initial")
            return Commanded(self.number(d, "initial", path, unit=model.input_unit))
        return read_series(self, d, path, self.base)

    # -- integrator --------------------------------------------------------------------------------
    def integrator(self, value: object, path: KeyPath, parent: dict[str, Any], model: ModelSpec) -> IntegratorSpec:
        robot = model.kind == "robot"
        if value is None:
            return IntegratorSpec("RK4", max_step=ROBOT_STEP) if robot else IntegratorSpec()
        d = self.mapping(value, path, parent, "integrator")
        self.keys(d, path, ("method", "rtol", "atol", "max_step"))
        method = self.string(d, "method", path, default="auto", choices=METHODS)
        if robot:
            if method not in ("auto", "RK4"):
                raise self.error(f"a robot scene integrates with fixed RK4 steps (its motors and friction are "
                                 f"sampled once per step), not {method}", path + ("method",), d, "method")
            step = self.number(d, "max_step", path, unit="s", default=ROBOT_STEP, lo=0.0, lo_open=True, hi=0.1)
            return IntegratorSpec("RK4", max_step=step)
        rtol = self.number(d, "rtol", path, unit="", default=1e-8, lo=1e-13, hi=0.1)
        atol = self.number(d, "atol", path, unit="(the state's units: m, rad and their rates)", default=1e-10, lo=0.0, lo_open=True)
        max_step = self.number(d, "max_step", path, unit="s", default=math.inf, lo=0.0, lo_open=True, allow_inf=True)
        if method == "RK4" and not math.isfinite(max_step):
            raise self.error("RK4 takes fixed steps of max_step [s]: give it (e.g. max_step: 0.001)", path, d,
                             "method")
        return IntegratorSpec(method, rtol, atol, max_step)


def _node_names(model: ModelSpec) -> tuple[str, ...]:
    if model.kind == "class2":
        from tensegrity_core.class2.geometry import NODE_NAMES

        return NODE_NAMES
    return model.structure.node_names


def _plain(value: Any) -> Any:
    """The parsed scene as plain dicts and lists (for saving with a trajectory)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value
