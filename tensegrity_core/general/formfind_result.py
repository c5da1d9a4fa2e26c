"""What form-finding reports: the per-iteration information, the result and how it is made.

Shared by every method (:mod:`.formfind`'s Newton, :mod:`.relaxation`), so neither imports
the other. The result carries the convergence measure of :mod:`.convergence` (``residual``,
dimensionless; ``residual_norm`` [N, N m]) and the stability verdict of :mod:`.stability`
(``min_eigenvalue``, ``stability_margin``, ``stable``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.convergence import FLOOR_FACTOR, Balance, balance
from tensegrity_core.general.stability import LowestMode, lowest_mode
from tensegrity_core.general.statics import forces_from_lengths, member_lengths, potential_energy
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure

FloatArray = NDArray[np.float64]

#: Up to this many degrees of freedom Newton (``linear_solver="auto"``) and the stability
#: check use dense linear algebra.
DENSE_LIMIT: Final = 300



class FormFindStatus(IntEnum):
    """Why form-finding stopped (:data:`STATUS_MESSAGES` says it in words). Integers, numbered
    as scipy numbers its results' statuses (0 is success): a result's ``status`` compares
    equal to its number and is written as the number in JSON."""

    STABLE = 0
    MAX_ITERATIONS = 1
    LINE_SEARCH_STALLED = 2
    UNSTABLE = 3
    UNSTIFFENED = 4
    CALLBACK = 5
    NON_FINITE = 6
    DIVERGED = 7


#: What each status means: the start of a result's message.
STATUS_MESSAGES: Final = {
    FormFindStatus.STABLE: "converged to a stable equilibrium",
    FormFindStatus.MAX_ITERATIONS: "maximum number of iterations reached",
    FormFindStatus.LINE_SEARCH_STALLED: "line search found no lower potential energy along the step",
    FormFindStatus.UNSTABLE: "converged to an unstable equilibrium",
    FormFindStatus.UNSTIFFENED: "converged to an equilibrium with an unstiffened mechanism (zero stiffness)",
    FormFindStatus.CALLBACK: "stopped by the callback",
    FormFindStatus.NON_FINITE: "the iteration produced non-finite values",
    FormFindStatus.DIVERGED: "diverged: the potential energy falls without bound (no equilibrium, e.g. unbalanced "
                             "loads on a structure free to move)",
}


def structure_size(structure: Structure) -> float:
    """Largest extent of the drawing [m] (1 for a single point)."""
    return float(np.ptp(structure.nodes, axis=0).max()) or 1.0


def diverged(config: Configuration, size: float) -> bool:
    """Whether a node has moved farther than 1e6 structure sizes from the origin of the
    drawing (the sign of a potential unbounded below)."""
    return bool(np.abs(config.coords).max() > 1e6 * size)


@dataclass
class IterationInfo:
    """What the callback receives after every iteration.

    ``residual`` the relative residual (dimensionless, :mod:`.convergence`), ``energy``
    [J], ``step_length`` the line search factor ``x`` of Eq. 83, ``step_norm`` the
    Euclidean norm of ``x dU``, ``shift`` the identity shift added to the Jacobi-scaled
    ``K_T``, ``min_eigenvalue`` the smallest scaled eigenvalue when the method computed it
    (dense Newton, an indefinite sparse matrix) else ``None``, ``residual_norm`` the
    Euclidean norm of the out-of-balance forces and moments [N, N m].
    """

    iteration: int
    residual: float
    energy: float
    step_length: float
    step_norm: float
    shift: float | None = None
    min_eigenvalue: float | None = None
    residual_norm: float = float("nan")


@dataclass
class FormFindResult:
    """Outcome of form-finding (scipy ``OptimizeResult`` style).

    ``nodes`` (n, 3) [m], ``member_forces`` (m,) [N, tension +], ``member_lengths`` (m,) [m],
    in the order of the description. ``residual`` the relative residual (dimensionless: the
    largest out-of-balance force at a free node over the forces that meet there, moments of
    rigid bodies likewise; :mod:`.convergence`), ``residual_norm`` [N, N m] the Euclidean
    norm of all out-of-balance forces and moments, ``force_residual`` [N] and
    ``moment_residual`` [N m] their largest components; ``min_eigenvalue`` the smallest
    eigenvalue of ``K_T`` (units of ``U``) excluding ``rigid_body_modes`` zero-energy rigid
    motions, ``stability_margin`` the smallest eigenvalue of the Jacobi-scaled ``K_T`` over
    its rounding level (NaN when not computed; > 1 stable, < -1 unstable), ``stable`` whether
    it is > 1; ``timings`` the seconds spent iterating and checking stability;
    ``configuration`` restarts form-finding (``form_find(..., x0=result.configuration)``).
    """

    success: bool
    status: FormFindStatus
    message: str
    nodes: FloatArray
    member_forces: FloatArray
    member_lengths: FloatArray
    iterations: int
    residual: float
    min_eigenvalue: float
    stable: bool
    history: list[dict[str, Any]] = field(default_factory=list)
    method: str = ""
    residual_norm: float = float("nan")
    force_residual: float = float("nan")
    moment_residual: float = float("nan")
    stability_margin: float = float("nan")
    energy: float = float("nan")
    rigid_body_modes: int = 0
    timings: dict[str, float] = field(default_factory=dict)
    configuration: Configuration | None = field(default=None, repr=False)
    structure: Structure | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """Plain data for YAML/JSON: nodes and members by name, in description order."""
        s = self.structure
        assert s is not None, "a result made by form_find knows its structure"
        slack = s.is_string & (self.member_lengths < s.rest_lengths)
        return {
            "structure": s.name,
            "success": bool(self.success),
            "status": int(self.status),
            "message": self.message,
            "method": self.method,
            "iterations": int(self.iterations),
            "residual": float(self.residual),
            "residual_norm": float(self.residual_norm),
            "force_residual": float(self.force_residual),
            "moment_residual": float(self.moment_residual),
            "energy": float(self.energy),
            "min_eigenvalue": float(self.min_eigenvalue),
            "stability_margin": float(self.stability_margin),
            "stable": bool(self.stable),
            "rigid_body_modes": int(self.rigid_body_modes),
            "nodes": {n: [float(v) for v in xyz] for n, xyz in zip(s.node_names, self.nodes)},
            "members": {
                name: {"force": float(t), "length": float(l), "rest_length": float(l0),
                       "force_density": float(t / l), "slack": bool(sl)}
                for name, t, l, l0, sl in zip(s.member_names, self.member_forces,
                                              self.member_lengths, s.rest_lengths, slack)
            },
        }


def make_result(structure: Structure, config: Configuration, status: FormFindStatus, iterations: int,
                history: list[dict[str, Any]], method: str, *, tol: float, dense: bool, check_stability: bool,
                low: LowestMode | None = None, reason: str | None = None,
                timings: dict[str, float] | None = None, stalled: bool = False) -> FormFindResult:
    """Build the result: forces, lengths, residual and stability (computed here when
    ``check_stability`` and converged and not given as ``low``; a converged but unstable or
    neutral equilibrium becomes UNSTABLE or UNSTIFFENED). ``reason`` replaces the message;
    ``stalled``: STABLE means the line search stopped there (the result can only be UNSTABLE
    or UNSTIFFENED: a state where the energy does not fall, not balanced to ``tol``)."""
    timings = dict(timings or {})
    bal = balance(structure, config)
    lengths = member_lengths(structure, config.coords)
    if low is None and check_stability and status == FormFindStatus.STABLE:
        started = time.perf_counter()
        low = lowest_mode(tangent_stiffness(structure, config, sparse=not dense), config, dense=dense)
        timings["stability"] = timings.get("stability", 0.0) + time.perf_counter() - started
    stable = bool(low is not None and low.verdict == "stable")
    if status == FormFindStatus.STABLE and check_stability and low is not None and not stable:
        status = FormFindStatus.UNSTIFFENED if low.verdict == "neutral" else FormFindStatus.UNSTABLE
    return FormFindResult(
        success=status == FormFindStatus.STABLE, status=status,
        message=_message(structure, config, status, iterations, bal, tol, low, checked=check_stability, reason=reason,
                         stalled=stalled),
        nodes=config.coords.copy(), member_forces=forces_from_lengths(structure, lengths), member_lengths=lengths,
        iterations=iterations, residual=bal.residual,
        min_eigenvalue=low.value if low is not None else float("nan"), stable=stable,
        history=history, method=method, residual_norm=bal.residual_norm,
        force_residual=bal.physical.force_residual, moment_residual=bal.physical.moment_residual,
        stability_margin=low.margin if low is not None else float("nan"),
        energy=potential_energy(structure, config.coords),
        rigid_body_modes=low.rigid_body_modes if low is not None else 0, timings=timings,
        configuration=config, structure=structure)


def _message(structure: Structure, config: Configuration, status: FormFindStatus, iterations: int, bal: Balance,
             tol: float, low: LowestMode | None, *, checked: bool, reason: str | None, stalled: bool) -> str:
    if reason is not None:
        return reason
    message = STATUS_MESSAGES[status]
    if status == FormFindStatus.STABLE and not checked:
        message = "converged (stability not checked)"
    if stalled:
        message = {FormFindStatus.UNSTABLE: "stopped where the structure is unstable",
                   FormFindStatus.UNSTIFFENED: "stopped at an unstiffened mechanism (zero stiffness)"}[status]
        message += (f": the line search found no lower energy along the Newton step after {iterations} "
                    f"iterations, residual {bal.residual:.3g}")
    row = bal.at_rounding_level(tol)
    if status in (FormFindStatus.STABLE, FormFindStatus.UNSTABLE, FormFindStatus.UNSTIFFENED) and row is not None \
            and not stalled:
        message += (f" (residual {bal.residual:.3g} above tol {tol:.3g} at {bal.row_name(row)}: within the "
                    f"rounding level of the forces there{_floor_member(structure, config, bal, row)})")
    if status in (FormFindStatus.UNSTABLE, FormFindStatus.UNSTIFFENED) and low is not None:
        message += (f" (smallest scaled stiffness eigenvalue {low.scaled:.3g}, {low.margin:.3g} times its "
                    f"rounding level {low.rounding:.3g})")
    elif status in (FormFindStatus.NON_FINITE, FormFindStatus.DIVERGED):
        message += f" after {iterations} iterations"
    if status == FormFindStatus.MAX_ITERATIONS:
        message += f" ({iterations}); residual {bal.residual:.3g}"
    if status == FormFindStatus.LINE_SEARCH_STALLED:
        message += f" after {iterations} iterations; residual {bal.residual:.3g}"
        stuck = bal.imbalance > tol * bal.scale + FLOOR_FACTOR * bal.floor
        if np.all(bal.imbalance[stuck] <= 10.0 * FLOOR_FACTOR * bal.floor[stuck]):
            worst = int(np.argmax(np.where(stuck, bal.relative, -1.0)))
            message += (f"; at {bal.row_name(worst)} that is within 10x the rounding level of the forces"
                        f"{_floor_member(structure, config, bal, worst)}")
    return message


def _floor_member(structure: Structure, config: Configuration, bal: Balance, row: int) -> str:
    """Which member sets the rounding level at ``row``: the one whose force is least certain
    (``EA/l0`` times ``eps (|x_a| + |x_b|)``), as '' or '; member ...'."""
    nodes = bal.row_nodes(row, structure)
    at = np.isin(structure.members, nodes).any(axis=1)
    if not at.any():
        return ""
    reach = np.linalg.norm(config.coords, axis=1)
    k = structure.EA / structure.rest_lengths
    a, b = structure.members[:, 0], structure.members[:, 1]
    uncertain = np.where(at, k * np.finfo(float).eps * (reach[a] + reach[b]), -1.0)
    i = int(np.argmax(uncertain))
    return (f"; member {structure.member_names[i]!r}: EA/l0 = {k[i]:.3g} N/m, force known to {uncertain[i]:.3g} N, "
            f"rest length {structure.rest_lengths[i]:.3g} m = {structure.rest_lengths[i] / structure_size(structure):.3g} "
            f"of the structure size")
