"""One model's kernels: the right-hand side and the placement of one state or of a batch.

An :class:`Evaluator` binds a :class:`~.plan.Plan` to a kernel family (:mod:`.jit`:
compiled loops or numpy arrays). It keeps no state between calls: every call allocates its
results, so one evaluator serves any number of states, threads and copies of a model.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from functools import cached_property
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.sim.general.kernels import arrays, loops
from tensegrity_core.sim.general.kernels.jit import choose_kernels
from tensegrity_core.sim.general.kernels.pattern import JacobianPattern
from tensegrity_core.sim.general.kernels.plan import Plan, frozen

FloatArray = NDArray[np.float64]


def _arg(a: ArrayLike) -> FloatArray:
    """``a`` as a writable C-ordered float64 array (copied only if it is not one): the
    compiled kernels are compiled once, for that kind of array (a plan's arrays are of
    another kind, :func:`~.plan.frozen`)."""
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, dtype=np.float64, order="C")


@dataclass(frozen=True)
class Evaluation:
    """A batch of ``B`` states evaluated: ``derivative`` (B, 2 n_dof) ``dy/dt``; node
    ``positions`` and ``velocities`` (B, n, 3) [m, m/s]; body ``rotations`` (B, nb, 3, 3);
    member ``lengths`` [m] and ``forces`` [N] (B, m) (positive = tensile, dampers included,
    zero while slack)."""

    derivative: FloatArray
    positions: FloatArray
    velocities: FloatArray
    rotations: FloatArray
    lengths: FloatArray
    forces: FloatArray


class Evaluator:
    """The kernels of ``plan``: ``kernels`` is ``"numba"``, ``"numpy"`` or None (numba where
    installed, unless ``TENSEGRITY_KERNELS`` says otherwise; :func:`~.jit.choose_kernels`)."""

    def __init__(self, plan: Plan, kernels: str | None = None):
        self.plan = frozen(plan)
        self.kernels = choose_kernels(kernels)
        self._module: ModuleType = loops if self.kernels == "numba" else arrays
        #: The numpy kernels' gathers and sums (None for the compiled loops).
        self.sums: arrays.Sums | None = None if self.kernels == "numba" else \
            arrays.plan_sums(plan)
        #: Objects of this plan's topology built on first use by their users (the numpy
        #: kernels' flat stages keep their layout here), shared with :meth:`with_plan`'s evaluators.
        self.shared: dict[str, Any] = {}

    def evaluate(self, y: FloatArray, R_ref: FloatArray, l0: FloatArray) -> Evaluation:
        """States ``y`` (B, 2 n_dof) in the charts ``R_ref`` (B, nb, 3, 3) with rest lengths
        ``l0`` (B, m) [m]."""
        plan = self.plan
        B = len(y)
        n, nb, m = plan.n_nodes, len(plan.body_dof), len(plan.EA)
        out = np.empty((B, 2 * plan.n_dof))
        X, V = np.empty((B, n, 3)), np.empty((B, n, 3))
        R = np.empty((B, nb, 3, 3))
        lengths, forces = np.empty((B, m)), np.empty((B, m))
        if self.sums is None:
            loops.derivatives(*plan, _arg(y), _arg(R_ref), _arg(l0), out, X, V, R, lengths, forces)
        else:
            arrays.derivatives(*plan, _arg(y), _arg(R_ref), _arg(l0), out, X, V, R, lengths, forces, self.sums)
        return Evaluation(out, X, V, R, lengths, forces)

    def derivative(self, y: FloatArray, R_ref: FloatArray, l0: FloatArray) -> FloatArray:
        """``dy/dt`` (2 n_dof,) of one state ``y`` in the charts ``R_ref`` (nb, 3, 3) with rest
        lengths ``l0`` (m,)."""
        ydot: FloatArray = loops.rate(*self.plan, _arg(y), _arg(R_ref), _arg(l0)) if self.sums is None else \
            arrays.rate(*self.plan, _arg(y), _arg(R_ref), _arg(l0), self.sums)
        return ydot

    def with_plan(self, plan: Plan) -> Evaluator:
        """The same kernels on ``plan``, a plan of the same topology (other member constants):
        the Jacobian's pattern, if built, the numpy kernels' sums and :attr:`shared` are shared."""
        new = copy.copy(self)
        new.plan = frozen(plan)
        return new

    @cached_property
    def pattern(self) -> JacobianPattern:
        """The Jacobian's sparsity pattern (built on first use)."""
        return JacobianPattern(self.plan)

    def jacobian(self, y: FloatArray, R_ref: FloatArray, l0: FloatArray) -> Any:
        """``d(dy/dt)/dy`` of one state as a scipy.sparse CSC matrix (untyped: Any) of the fixed
        :attr:`pattern`, its values computed in blocks and gathered in CSC order. Each call
        returns a matrix with its own values: an implicit solver keeps the last one while
        another state of the same model (a copy) asks for its own."""
        pat = self.pattern
        T = np.empty((pat.n_groups, 6, 6))
        position, velocity = np.empty((pat.n_blocks, 6, 6)), np.empty((pat.n_blocks, 6, 6))
        self._module.jacobian_blocks(*self.plan, pat.group_dofs, pat.group_size, pat.group_body, pat.node_group,
                                     pat.node_selection, pat.member_blocks, pat.diagonal_block, pat.block_rows,
                                     pat.block_cols, _arg(y), _arg(R_ref), _arg(l0), T, position, velocity)
        values = np.concatenate([T.ravel(), position.ravel(), velocity.ravel()])
        return pat.matrix(values[pat.source])
