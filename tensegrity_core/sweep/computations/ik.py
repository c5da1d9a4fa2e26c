"""``ik``: the class-2 mechanism's inverse kinematics over a set of targets, per point.

The point's scene (a class-2 scene) gives the mechanism's parameters (``model.params``;
nothing else of the scene is used);
``inverse_kinematics`` solves every target D = (x, y) [m] of ``targets``: a list of
``[x, y]`` pairs or a grid ``{x: {from, to, num}, y: {from, to, num}}``; ``paper_range``
(default true) restricts the solutions to the paper's angle range. Results: ``reachable``
(targets with a valid solution), ``reachable_fraction``, ``min_singularity_distance`` (over
the reachable targets, each at its valid solution farthest from a singular set),
``max_fk_residual`` [m] and ``min_stiffness_beta`` (d2U/dbeta2 [J/rad^2]) over the valid
solutions.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from tensegrity_core.sweep.checks import Check, OptionError, boolean, number
from tensegrity_core.sweep.computations.computation import Computation
from tensegrity_core.sweep.computations.results import Options, ResultDef, ResultSpec, scalar
from tensegrity_core.sweep.points import grid_values

if TYPE_CHECKING:
    from tensegrity_core.class2.inverse_kinematics import IKCandidate
    from tensegrity_core.class2.params import Class2Params

MAX_TARGETS = 100_000


def targets(value: object) -> tuple[tuple[float, float], ...]:
    """``[[x, y], ...]`` or ``{x: {from, to, num}, y: {from, to, num}}`` -> ((x, y), ...)."""
    finite = number()
    out: list[tuple[float, float]]
    if isinstance(value, list):
        out = []
        for i, pair in enumerate(value):
            if not (isinstance(pair, list) and len(pair) == 2):
                raise OptionError(f"item [{i}] must be a pair [x, y], got {pair!r}")
            try:
                out.append((finite(pair[0]), finite(pair[1])))
            except OptionError as err:
                raise OptionError(f"item [{i}]: {err}") from None
    elif isinstance(value, dict) and set(value) == {"x", "y"}:
        axes = []
        for key in ("x", "y"):
            g = value[key]
            if not (isinstance(g, dict) and set(g) == {"from", "to", "num"}):
                raise OptionError(f"{key} must be {{from, to, num}}, got {g!r}")
            num = g["num"]
            if isinstance(num, bool) or not isinstance(num, int) or num < 1:
                raise OptionError(f"{key}.num must be an integer >= 1, got {num!r}")
            axes.append(grid_values(finite(g["from"]), finite(g["to"]), num))
        out = [(x, y) for x in axes[0] for y in axes[1]]
    else:
        raise OptionError(f"must be a list of [x, y] pairs or {{x: {{from, to, num}}, y: {{...}}}}, got {value!r}")
    if not out:
        raise OptionError("needs at least one target")
    if len(out) > MAX_TARGETS:
        raise OptionError(f"at most {MAX_TARGETS} targets, got {len(out)}")
    return tuple(out)


@dataclass
class Solved:
    """Per target: the valid solutions of the IK."""

    valid: list[list[IKCandidate]]

    def over_valid(self, field: str, pick: Callable[[list[float]], Any]) -> float:
        values = [getattr(c, field) for sols in self.valid for c in sols]
        return float(pick(values)) if values else math.nan


def _min_singularity_distance(s: Solved) -> float:
    best = [max(c.singularity_distance for c in sols) for sols in s.valid if sols]
    return float(min(best)) if best else math.nan


class InverseKinematics(Computation["Class2Params", Solved]):
    name = "ik"
    base = "scene"
    model = "class2"
    options: dict[str, Check] = {"targets": targets, "paper_range": boolean}
    results: dict[str, ResultDef[Solved]] = {
        "reachable": scalar("reachable", "int", lambda s: sum(1 for v in s.valid if v), "targets solved", "count"),
        "reachable_fraction": scalar("reachable_fraction", "float",
                                     lambda s: sum(1 for v in s.valid if v) / len(s.valid), "fraction solved", "1"),
        "min_singularity_distance": scalar("min_singularity_distance", "float", _min_singularity_distance,
                                           "distance to the nearest singular set (dimensionless)", "1"),
        "max_fk_residual": scalar("max_fk_residual", "float", lambda s: s.over_valid("fk_residual", np.max),
                                  "[m]", "m"),
        "min_stiffness_beta": scalar("min_stiffness_beta", "float", lambda s: s.over_valid("stiffness_beta", np.min),
                                     "d2U/dbeta2 [J/rad^2]", "J/rad^2"),
    }
    required: dict[str, tuple[str, ...]] = {}
    required_options = ("targets",)
    uses_seed = False
    modules = ("tensegrity_core.class2",)

    def load(self, document: dict[str, Any]) -> Class2Params:
        """The mechanism's parameters from the scene's ``model.params`` (the rest of the scene,
        its initial state and inputs, plays no part in the IK)."""
        from tensegrity_core.class2.params import PAPER_PARAMS
        from tensegrity_core.errors import ParameterError

        params = (document.get("model") or {}).get("params", {})
        if not isinstance(params, dict):
            raise ParameterError(f"model.params must be a mapping, got {params!r}")
        return PAPER_PARAMS.with_overrides(params)

    def run(self, params: Class2Params, options: Options) -> tuple[bool, str, Solved]:
        from tensegrity_core.class2 import inverse_kinematics

        paper_range = options.get("paper_range", True)
        valid = [list(inverse_kinematics(x, y, params, paper_range=paper_range).valid)
                 for x, y in options["targets"]]
        n = sum(1 for v in valid if v)
        return True, f"{n} of {len(valid)} targets reachable", Solved(valid)

    def probe(self, document: dict[str, Any], options: Options, *, full: bool = True) -> Solved:
        return self.run(self.load(document), options)[2]

    def finish_options(self, options: Options, results: Sequence[ResultSpec]) -> Options:
        return options


IK = InverseKinematics()
