"""``form_find`` and ``stiffness``: the equilibrium of the point's structure, and its modes.

``form_find`` runs ``tensegrity_core.general.form_find`` (options ``method``, ``tol`` (on the
relative residual, docs/general.md), ``max_iter``). Results: ``iterations``, ``residual``
(relative: out-of-balance force over the forces meeting at the node, largest), ``min_eigenvalue`` (smallest
eigenvalue of K_T, rigid-body modes excluded), ``stable``, ``energy`` [J],
``max_member_force`` / ``min_member_force`` [N, tension +], ``slack_members`` (strings
shorter than their rest length), ``node`` {name} (its equilibrium position,
``<name>_x/_y/_z`` [m]) and ``error_vs_reference`` (the largest distance of a node from its
place in the unvaried base structure's equilibrium [m]). A form-finding that does not reach a
stable equilibrium makes the point *failed*, with these results as far as they exist.

``stiffness`` form-finds first, then adds the modes at the equilibrium: ``eigenvalues`` {n}
(the ``n`` lowest eigenvalues of K_T, rigid-body modes included, ``eigenvalue_0`` ...),
``rank`` of the equilibrium matrix, ``self_stress_modes`` and ``mechanism_modes``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sweep.checks import Check, OptionError, choice, integer, number, text
from tensegrity_core.sweep.computations.computation import Computation
from tensegrity_core.sweep.computations.results import Column, Options, Probe, ResultDef, ResultSpec, scalar

if TYPE_CHECKING:
    from tensegrity_core.general import FormFindResult, Modes, Structure


@dataclass
class Equilibrium:
    """A form-finding result with the structure, and (``stiffness``) its modes."""

    structure: Structure
    result: FormFindResult
    modes: Modes | None = None
    eigenvalues: NDArray[np.float64] | None = None


def _forces(out: Equilibrium, pick: Callable[[NDArray[np.float64]], Any]) -> float:
    t = out.result.member_forces
    return float(pick(t)) if t.size and np.isfinite(t).all() else math.nan


def _node_columns(options: Options, data: object) -> list[Column]:
    return [(f"{options['name']}_{a}", "float") for a in "xyz"]


def _node_position(out: Equilibrium, options: Options, data: object) -> list[float]:
    names = out.structure.node_names
    if options["name"] not in names:
        return [math.nan] * 3
    return [float(v) for v in out.result.nodes[names.index(options["name"])]]


def _check_node(options: Options, probe: Probe[Equilibrium], folder: str) -> None:
    names = probe().structure.node_names
    if options["name"] not in names:
        from tensegrity_core.schema import suggest

        raise OptionError(f"the structure has no node {options['name']!r}{suggest(options['name'], names)}")
    return None


def _reference_nodes(options: Options, probe: Probe[Equilibrium], folder: str) -> NDArray[np.float64]:
    base = probe()
    if not base.result.success:
        raise OptionError(f"the base structure's own form-finding (the reference) failed: {base.result.message}")
    return np.asarray(base.result.nodes, dtype=float)


def _node_error(out: Equilibrium, options: Options, data: NDArray[np.float64]) -> list[float]:
    nodes = np.asarray(out.result.nodes, dtype=float)
    if nodes.shape != data.shape:
        return [math.nan]
    return [float(np.max(np.linalg.norm(nodes - data, axis=1)))]


def _slack(out: Equilibrium) -> int:
    s, r = out.structure, out.result
    return int(np.sum(s.is_string & (r.member_lengths < s.rest_lengths)))


#: The unit of K_T's eigenvalues: N/m along a node's or a body centre's translation, N m/rad
#: along a body's rotation (a mode mixes both where the structure has rigid bodies).
KT_UNIT = "N/m, N m/rad"

FORM_FIND_RESULTS: dict[str, ResultDef[Equilibrium]] = {
    "iterations": scalar("iterations", "int", lambda o: int(o.result.iterations), "Newton iterations", "count"),
    "residual": scalar("residual", "float", lambda o: float(o.result.residual),
                       "relative out-of-balance force (largest over nodes) [-]", "1"),
    "min_eigenvalue": scalar("min_eigenvalue", "float", lambda o: float(o.result.min_eigenvalue),
                             "smallest eigenvalue of K_T (rigid-body modes excluded)", KT_UNIT),
    "stable": scalar("stable", "bool", lambda o: bool(o.result.stable), "stable equilibrium", ""),
    "energy": scalar("energy", "float", lambda o: float(o.result.energy), "potential energy [J]", "J"),
    "max_member_force": scalar("max_member_force", "float", lambda o: _forces(o, np.max), "[N]", "N"),
    "min_member_force": scalar("min_member_force", "float", lambda o: _forces(o, np.min), "[N]", "N"),
    "slack_members": scalar("slack_members", "int", _slack, "slack strings", "count"),
    "node": ResultDef(doc="equilibrium position of a node [m]", columns=_node_columns, extract=_node_position,
                      options={"name": text}, prepare=_check_node, unit="m"),
    "error_vs_reference": ResultDef(
        doc="largest node distance from the base structure's equilibrium [m]",
        columns=lambda o, d: [("error_vs_reference", "float")], extract=_node_error,
        prepare=_reference_nodes, unit="m"),
}


class FormFind(Computation["Structure", Equilibrium]):
    name = "form_find"
    base = "structure"
    model = None
    options: dict[str, Check] = {"method": choice("newton", "dynamic_relaxation"),
                                 "tol": number(lo=0.0, lo_open=True), "max_iter": integer()}
    results = FORM_FIND_RESULTS
    required = {"node": ("name",)}
    uses_seed = False
    required_options: tuple[str, ...] = ()
    modules = ("tensegrity_core.general",)

    def load(self, document: dict[str, Any]) -> Structure:
        from tensegrity_core.general import load_structure

        return load_structure(document)

    def run(self, structure: Structure, options: Options) -> tuple[bool, str, Equilibrium]:
        from tensegrity_core.general import form_find

        result = form_find(structure, method=options.get("method", "newton"), tol=options.get("tol"),
                           max_iter=options.get("max_iter"))
        return result.success, result.message, Equilibrium(structure, result)

    def probe(self, document: dict[str, Any], options: Options, *, full: bool = True) -> Equilibrium:
        return self.run(self.load(document), options)[2]

    def finish_options(self, options: Options, results: Sequence[ResultSpec]) -> Options:
        return options


def _eigen_columns(options: Options, data: object) -> list[Column]:
    return [(f"eigenvalue_{i + 1}", "float") for i in range(options.get("n", 1))]    # from 1, the lowest


def _eigenvalues(out: Equilibrium, options: Options, data: object) -> list[float]:
    n = options.get("n", 1)
    w = out.eigenvalues if out.eigenvalues is not None else np.array([])
    return [float(w[i]) if i < len(w) else math.nan for i in range(n)]


def _modes_count(read: Callable[[Modes], Any]) -> Callable[[Equilibrium], int | None]:
    return lambda o: None if o.modes is None else int(read(o.modes))


class Stiffness(FormFind):
    name = "stiffness"
    results = {
        **FORM_FIND_RESULTS,
        "eigenvalues": ResultDef(doc="lowest eigenvalues of K_T", columns=_eigen_columns, extract=_eigenvalues,
                                 options={"n": integer(lo=1)}, unit=KT_UNIT),
        "rank": scalar("rank", "int", _modes_count(lambda m: m.rank), "rank of the equilibrium matrix", "count"),
        "self_stress_modes": scalar("self_stress_modes", "int", _modes_count(lambda m: m.self_stress.shape[1]),
                                    "self-stress modes", "count"),
        "mechanism_modes": scalar("mechanism_modes", "int", _modes_count(lambda m: m.mechanisms.shape[1]),
                                  "mechanism modes (rigid-body motions included)", "count"),
    }

    def run(self, structure: Structure, options: Options) -> tuple[bool, str, Equilibrium]:
        from tensegrity_core.general import modal_analysis, modes

        ok, message, out = super().run(structure, options)
        if out.result.configuration is not None and np.isfinite(out.result.nodes).all():
            config = out.result.configuration
            out.modes = modes(structure, config)
            out.eigenvalues = modal_analysis(structure, config, n_modes=options.get("modes", 1)).eigenvalues
        return ok, message, out

    def finish_options(self, options: Options, results: Sequence[ResultSpec]) -> Options:
        """Compute as many eigenvalues as the ``eigenvalues`` results ask for."""
        n = max([r.options.get("n", 1) for r in results if r.name == "eigenvalues"], default=1)
        return {**options, "modes": n}


FORM_FIND = FormFind()
STIFFNESS = Stiffness()
