"""Units and readable names of what a sweep varies and keeps, for its plots' axes.

The formats are SI throughout (docs/scenes.md, docs/structures.md); :func:`quantity_label`
names a varied quantity with its unit from its key path, :func:`coordinate_unit` gives the
unit of a coordinate of a run by its name (``rho1`` m, ``beta`` rad, ``x_top.rx`` rad,
``v_top.cx`` m/s). Result columns carry their units from their definitions
(:attr:`~tensegrity_core.sweep.computations.results.ResultDef.unit`).
"""

from __future__ import annotations

from typing import Final

from tensegrity_core.schema import KeyPathError, parse_pattern
from tensegrity_core.sweep.points import Quantity

#: Units of numeric leaves of a scene or a structure, by their key (where the key alone says).
KEY_UNITS: Final = {
    "L": "m", "m": "kg", "mass": "kg", "ka": "N/m", "kb": "N/m", "k": "N/m", "c": "N s/m",
    **{f"k{i}": "N/m" for i in range(1, 5)}, **{f"c{i}": "N s/m" for i in range(1, 5)},
    "rho1": "m", "rho2": "m", "t0": "s", "t1": "s", "duration": "s", "tau": "s", "max_step": "s", "rate": "Hz",
    "stiffness": "N/m", "drive_damping": "N s/m", "restitution": "1", "rest_velocity": "m/s", "rtol": "1",
    "seed": "1", "rest_length": "m", "l0": "m", "rest_length_ratio": "1", "l0_ratio": "1", "EA": "N",
    "E": "Pa", "A": "m^2",
}
#: Names of the class-2 parameters, for axis labels.
NAMES: Final = {"L": "strut length L", "m": "strut mass m", "k": "spring stiffness k", "c": "damping c",
                "ka": "spring stiffness ka", "kb": "spring stiffness kb",
                **{f"k{i}": f"spring stiffness k{i}" for i in range(1, 5)},
                **{f"c{i}": f"damping c{i}" for i in range(1, 5)}}
#: Keys that only hold others: not part of a readable name.
_HOLDERS: Final = {"model", "params", "initial", "equilibrium", "inputs", "effects", "integrator", "output",
                   "structure", "members", "nodes", "defaults"}


def quantity_label(q: Quantity, *, class2: bool) -> str:
    """``"spring stiffness k [N/m]"``, ``"f1 gain [N/(m s)]"``, ``"side factor [1]"`` (a
    scaled quantity is a factor): the quantity's name (its ``name`` in the sweep file, else
    read from its key path) and its unit (``?`` where the key path does not tell)."""
    named = q.column != q.path
    if q.scale:
        return f"{q.column if named else 'factor on ' + readable(q.path)} [1]"
    return f"{q.column if named else readable(q.path)} [{key_unit(q.path, class2=class2) or '?'}]"


def readable(path: str) -> str:
    """A key path as words: its last key (a class-2 parameter by name) after what it belongs
    to (an input, an effect, a group of members): ``inputs.f1.gain`` -> ``f1 gain``."""
    try:
        tokens = parse_pattern(path)
    except KeyPathError:
        return path
    last = str(tokens[-1][1])
    owner = next((str(arg) for kind, arg in reversed(tokens[:-1])
                  if kind == "select" or (kind == "key" and arg not in _HOLDERS)), "")
    return f"{owner} {NAMES.get(last, last)}".strip()


def key_unit(path: str, *, class2: bool) -> str:
    """The unit of the value at key path ``path`` of a scene or structure (class-2 or a
    general structure), or ``""`` when the path does not tell."""
    try:
        tokens = parse_pattern(path)
    except KeyPathError:
        return ""
    keys = [str(arg) for kind, arg in tokens if kind != "index"]
    index = tokens[-1][1] if tokens[-1][0] == "index" else None
    last = keys[-1]
    if "damping" in keys and last == "beta":
        return "s"                                  # c = beta EA / l0
    if "inputs" in keys and last in ("value", "from", "to", "initial"):
        return "N" if class2 else "m"               # class-2 forces, general rest lengths
    if "inputs" in keys and last == "gain":
        return "N/(m s)"                            # f = gain rho t
    if last in ("vector", "gravity"):
        return "m/s^2"
    if {"loads", "preload"} & set(keys):
        return "N"
    if keys[0] == "nodes":
        return "m"
    if last in ("q", "qdot") and class2 and isinstance(index, int):
        return ("m", "m", "rad")[min(index, 2)] + ("/s" if last == "qdot" else "")
    return KEY_UNITS.get(last, "")


def coordinate_unit(name: str) -> str:
    """The unit of a run's coordinate (or its rate, ``_dot`` / ``v_``) by name: ``rho1`` m,
    ``beta`` rad, ``x_top.cx`` m, ``x_top.rx`` rad, ``v_top.cx`` m/s."""
    rate = name.endswith("_dot") or name.startswith("v_")
    base = name.removesuffix("_dot")
    axis = base.partition(".")[2]
    angle = base in ("beta", "alpha") or axis.startswith("r")
    return ("rad" if angle else "m") + ("/s" if rate else "")
