"""Every refusal of a number in a structure, scene or robot file names the field, the value,
the bound and the unit.

Each number of a description written to exercise every numeric key the formats take is set,
one at a time, beyond the largest magnitude a description may hold (1e15 in the key's
unit): the file must be refused in one line that names the key, the value given and the
bound in the key's unit. The units below are the ones the user's manual gives for each key
(docs/structures.md, docs/scenes.md, docs/robots.md), written here, not read from the code.
Cost: about 1 s (one load per distinct key, ~130 loads).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tensegrity_core.general import example_path, structure_from_dict
from tensegrity_core.robot.loading import robot_path
from tensegrity_core.robot.robot_schema import robot_from_dict
from tensegrity_core.schema import SchemaError, parse_yaml
from tensegrity_core.sim import scene_path
from tensegrity_core.sim.scene import SCENES_DIR, scene_from_dict

BEYOND = -1e16
DIMENSIONLESS = ""

#: key -> its unit as the manual gives it ("" for a dimensionless number).
UNITS = {
    # structures (docs/structures.md)
    "E": "Pa", "A": "m^2", "EA": "N", "rest_length": "m", "rest_length_ratio": DIMENSIONLESS, "mass": "kg",
    "loads": "N", "masses": "kg", "gravity": "m/s^2", "nodes": "m",
    # robots (docs/robots.md)
    "radius": "m", "cap_mass": "kg", "cap_radius": "m", "inertia": "kg m^2", "stiffness": "N/m",
    "damping": "N s/m", "range": "m", "tau": "s", "max_speed": "m/s", "max_tension": "N", "dissipation": "s/m",
    "mu_static": DIMENSIONLESS, "mu_kinetic": DIMENSIONLESS, "tangential_stiffness": "N/m",
    "tangential_damping": "N s/m", "rolling_friction": "m", "torsional_friction": "m", "point": "m",
    "normal": DIMENSIONLESS, "angle": "deg",
    # scenes (docs/scenes.md)
    "duration": "s", "rate": "Hz", "L": "m", "m": "kg", "k": "N/m", "c": "N s/m", "ka": "N/m", "kb": "N/m",
    "beta": "s", "vector": "m/s^2", "drive_damping": "N s/m", "restitution": DIMENSIONLESS,
    "rest_velocity": "m/s", "rho1": "m", "rho2": "m", "lift": "m", "preload": "N", "gain": "N/(m s)",
    "t0": "s", "t1": "s", "rtol": DIMENSIONLESS, "atol": "(the state's units", "max_step": "s", "member_forces": "N", "nodes_noise": "m",
    "qdot": ("m/s", "m/s", "rad/s"), "q": ("m", "m", "rad"),
}
#: Keys whose unit depends on where they are: (parent key, key) -> unit.
UNITS_AT = {("incline", "heading"): "deg", ("roll", "heading"): DIMENSIONLESS,
            ("sensor_noise", "nodes"): "m", ("sensor_noise", "q"): "m or rad",
            ("f1", "value"): "N", ("f2", "from"): "N", ("f2", "to"): "N", ("long1", "initial"): "m"}


def _leaves(d: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """The key paths of every number in ``d``."""
    items = d.items() if isinstance(d, dict) else enumerate(d) if isinstance(d, list) else ()
    for k, v in items:
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            yield path + (k,)
        else:
            yield from _leaves(v, path + (k,))


def _unit(path: tuple[Any, ...], node_names: set[str]) -> tuple[str, str]:
    """(the key the refusal must name, its unit) for the number at ``path``."""
    keys = [k for k in path if isinstance(k, str)]
    index = path[-1] if isinstance(path[-1], int) else None
    key = keys[-1]
    parent = keys[-2] if len(keys) > 1 else ""
    if (parent, key) in UNITS_AT:
        return key, UNITS_AT[parent, key]
    if key in node_names:                    # nodes: {n0: [x, y, z]}, loads: {n: [...]}, masses: {n: m}
        return key, UNITS[parent]
    unit = UNITS[key]
    return key, unit[index] if isinstance(unit, tuple) and index is not None else unit


def _set(d: Any, path: tuple[Any, ...], value: float) -> Any:
    out = copy.deepcopy(d)
    target = out
    for k in path[:-1]:
        target = target[k]
    target[path[-1]] = value
    return out


def _pattern(path: tuple[Any, ...], node_names: set[str]) -> tuple[Any, ...]:
    """``path`` with list positions of entries and node names folded: one case per key."""
    return tuple("*" if (isinstance(k, int) and i < len(path) - 1) or k in node_names else k
                 for i, k in enumerate(path))


def _yaml(path: Any) -> Any:
    return parse_yaml(path.read_text())


def _robot() -> dict[str, Any]:
    d = _yaml(robot_path("six_bar"))
    d["rods"][0]["inertia"] = [0.5, 0.01]
    d["cables"][0] = {"name": "c0_4", "nodes": ["n0", "n4"], "stiffness": 4000.0, "damping": 50.0,
                      "rest_length_ratio": 1.0, "motor": {"range": [0.45, 1.5], "tau": 0.02, "max_speed": 0.5,
                                                          "max_tension": 2000.0}}
    d["floor"].update(dissipation=5.0, mu_kinetic=0.5, mu_static=1.0, tangential_stiffness=2e5,
                      tangential_damping=300.0, rolling_friction=0.001, torsional_friction=0.001,
                      point=[0.0, 0.0, 0.0], incline={"angle": 0.0, "heading": 10.0})
    return d


def _structure() -> dict[str, Any]:
    d = _yaml(example_path("tensegrity_table"))
    d["members"][0].update(EA=1.0e6, mass=1.0)
    d["members"][1].update(rest_length=0.2)
    d["members"][2].update(E=1.0e9, A=1.0e-4)
    d["defaults"]["mass"] = 0.5
    d["rigid_bodies"][1]["mass"] = 2.0
    d.update(loads={"c1": [0.0, 0.0, -1.0]}, masses={"hang": 0.1}, gravity=9.8)
    return d


def _class2_scene() -> dict[str, Any]:
    d = _yaml(scene_path("stiff_fold"))
    d["model"]["params"].update(ka=10.0)
    d["effects"] = ["inertia", "springs", {"damping": {}}, {"fold_limit": {"restitution": 0.5, "rest_velocity": 1e-6}},
                    {"actuator_compliance": {"stiffness": 1e6, "drive_damping": 0.1}},
                    {"sensor_noise": {"q": 1e-3, "member_forces": 0.01}}]
    d["initial"] = {"q": [0.7, 0.7, 1.0], "qdot": [0.0, 0.0, 0.0]}
    d["inputs"] = {"f1": {"law": "constant", "value": 1.0}, "f2": {"law": "ramp", "from": 0.0, "to": 1.0,
                                                                  "t0": 0.5, "t1": 1.0}}
    d["integrator"] = {"method": "RK4", "max_step": 1e-3}
    return d


def _general_scene() -> dict[str, Any]:
    d = _yaml(scene_path("table_actuated"))
    d["effects"] = ["inertia", "springs", {"damping": {"beta": 2e-3}}, {"gravity": {"vector": [0.0, 0.0, -9.8]}},
                    {"sensor_noise": {"nodes": 1e-3}}]
    d["initial"] = {"equilibrium": {"preload": {"c1": [0.0, 0.0, 1.0]}}}
    d["inputs"]["long1"] = {"law": "commanded", "initial": 0.9}
    d["integrator"]["rtol"] = 1e-6
    return d


def _robot_scene() -> dict[str, Any]:
    d = _yaml(scene_path("six_bar_roll"))
    d["effects"] = ["inertia", "cables", {"motors": {"tau": 0.02, "max_speed": 0.5, "max_tension": 2000.0}},
                    "gravity", {"contact": {"stiffness": 5e5, "dissipation": 5.0}},
                    {"friction": {"mu_static": 1.0, "mu_kinetic": 0.5, "tangential_stiffness": 2e5,
                                  "tangential_damping": 300.0, "rolling_friction": 0.001,
                                  "torsional_friction": 0.001}}, "sensors"]
    d["initial"] = {"drawn": True, "lift": 0.01}
    del d["inputs"]
    d["control"] = {"roll": {"faces": 1, "heading": [1.0, 0.0], "rate": 50.0}}
    return d


def _load_scene(d: Any) -> object:
    return scene_from_dict(d, base=SCENES_DIR)


DOCUMENTS: dict[str, tuple[Callable[[], Any], Callable[[Any], object]]] = {
    "robot": (_robot, robot_from_dict),
    "structure": (_structure, structure_from_dict),
    "class2 scene": (_class2_scene, _load_scene),
    "general scene": (_general_scene, _load_scene),
    "robot scene": (_robot_scene, _load_scene),
}


@pytest.mark.parametrize("kind", DOCUMENTS)
def test_a_number_beyond_its_bound_is_refused_with_field_value_bound_and_unit(kind):
    make, load = DOCUMENTS[kind]
    doc = make()
    load(doc)                                                # the document itself is fine
    nodes = set(_yaml(robot_path("six_bar"))["nodes"]) | set(_yaml(example_path("tensegrity_table"))["nodes"])
    seen: set[tuple[Any, ...]] = set()
    checked = 0
    for path in _leaves(doc):
        pattern = _pattern(path, nodes)
        if pattern in seen or path[0] in ("seed",) or "faces" in path:
            continue
        seen.add(pattern)
        key, unit = _unit(path, nodes)
        with pytest.raises(SchemaError) as err:
            load(_set(doc, path, BEYOND))
        message = str(err.value)
        bound = f"1e+15 {unit}" if unit else "1e+15 (dimensionless)"
        assert "\n" not in message and key in message and "-1e+16" in message and bound in message, (path, message)
        checked += 1
    assert checked >= 10, checked
