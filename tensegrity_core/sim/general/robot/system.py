"""A robot's equations for one stretch: the plan, the rotation charts and the input laws.

:class:`RobotSystem` binds a :class:`~.plan.RobotPlan` to a kernel family (compiled loops
or numpy arrays, :mod:`tensegrity_core.sim.general.kernels.jit`), the bodies' rotation
charts ``R_ref``, the motors' input laws and the commands they hold. It is immutable: a
re-charting or a new command gives a new instance (:meth:`with_chart`, :meth:`with_commands`). It offers the
right-hand side ``fun`` (what the fixed step integrates), whole fixed steps (:meth:`run`:
RK4 and the sampled update after each, in one kernel call) and the evaluation of a batch of
states for the observations (:meth:`evaluate`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.sim.general.kernels import body_arrays
from tensegrity_core.sim.general.kernels.jit import choose_kernels
from tensegrity_core.sim.general.kernels.plan import constant
from tensegrity_core.sim.general.robot import arrays, loops, step_loops
from tensegrity_core.sim.general.robot.plan import RobotPlan
from tensegrity_core.sim.inputs import Commanded, Constant, InputLaw

FloatArray = NDArray[np.float64]


def _arg(a: ArrayLike) -> FloatArray:
    """``a`` as a writable C-ordered float64 array (the kind the compiled kernels take)."""
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, dtype=np.float64, order="C")


@dataclass(frozen=True)
class RobotEvaluation:
    """A batch of ``B`` states evaluated: ``derivative`` (B, N); node ``positions``,
    ``velocities`` and the nodal ``forces`` of weights, cables and floor (B, n, 3) [m, m/s,
    N]; body ``rotations`` (B, nb, 3, 3); cables' ``rest_lengths``, ``lengths`` [m],
    ``rates`` [m/s], ``tensions`` [N] (B, c); caps' ``depth`` [m] (penetration, > 0 in
    contact), ``normal`` forces [N] (B, ncap), ``friction`` forces [N] and the rolling and spin
    resistance ``couple`` [N m] (B, ncap, 3); all of them pieces of one ``block``
    (:func:`empty_evaluation`)."""

    derivative: FloatArray
    positions: FloatArray
    velocities: FloatArray
    rotations: FloatArray
    forces: FloatArray
    rest_lengths: FloatArray
    lengths: FloatArray
    rates: FloatArray
    tensions: FloatArray
    depth: FloatArray
    normal: FloatArray
    friction: FloatArray
    couple: FloatArray
    #: The one array the fields above are pieces of (:func:`empty_evaluation`).
    block: FloatArray


class RobotSystem:
    """A robot's equations with the charts ``R_ref`` (nb, 3, 3), the motors' input
    ``laws`` (one per motor, its command in its mode: ``modes`` (a,), the values of
    :data:`tensegrity_core.robot.motor.MODES`, default all rest lengths [m]) and
    ``commands`` (a,), what each :class:`~tensegrity_core.sim.inputs.Commanded` law holds
    (the entries of other laws are ignored; default: none held, NaN); ``kernels``:
    ``"numba"``, ``"numpy"`` or None (numba where installed, unless ``TENSEGRITY_KERNELS``
    says otherwise)."""

    #: No contact mode in the stepper's sense (the caps' contact states are sampled state).
    mode: frozenset[int] = frozenset()
    #: No Jacobian: robot scenes take fixed explicit steps.
    jac = None

    def __init__(self, plan: RobotPlan, *, laws: Sequence[InputLaw], R_ref: ArrayLike,
                 commands: ArrayLike | None = None, modes: ArrayLike | None = None, kernels: str | None = None):
        self.plan = plan
        self.laws = tuple(laws)
        self.commands: FloatArray = np.full(len(self.laws), np.nan) if commands is None \
            else np.array(commands, dtype=np.float64)
        # which laws hold a command, which a scene's constant and which are evaluated in time,
        # told apart once: a new command changes only ``commands``
        self._commanded = np.array([j for j, law in enumerate(self.laws) if isinstance(law, Commanded)],
                                   dtype=np.intp)
        constants = [(j, law.value) for j, law in enumerate(self.laws) if isinstance(law, Constant)]
        self._constant = np.array([j for j, _ in constants], dtype=np.intp)
        self._constant_values = np.array([v for _, v in constants], dtype=np.float64)
        self._timed = tuple((j, law) for j, law in enumerate(self.laws)
                            if not isinstance(law, (Commanded, Constant)))
        # read-only, as the plan's arrays: a writable one is another signature of the compiled
        # kernels, compiled anew in each process instead of loaded from the warmed cache
        self.modes: NDArray[np.int64] = constant(np.asarray(
            np.zeros(len(plan.motor_cable)) if modes is None else modes, dtype=np.int64))
        self.R_ref = _arg(R_ref)
        self.kernels = choose_kernels(kernels)
        self._module: ModuleType = loops if self.kernels == "numba" else arrays
        self._steps: ModuleType = step_loops if self.kernels == "numba" else arrays
        # the numpy kernels' index arrays of the moving bodies and the cables, built once per plan
        self._options: dict[str, body_arrays.BodyIndex | arrays.CableIndex] = {} if self.kernels == "numba" else {
            "bodies": body_arrays.body_index(plan.on_body, plan.on_offset, plan.body_dof, plan.n_dof),
            "cables": arrays.cable_index(plan.cable_a, plan.cable_b)}

    def with_chart(self, R_ref: ArrayLike) -> RobotSystem:
        """The same equations in other rotation charts."""
        new = self._copy()
        new.R_ref = _arg(R_ref)
        return new

    def with_commands(self, commands: ArrayLike) -> RobotSystem:
        """The same equations with the commanded laws holding ``commands`` (a,) (a new command:
        the laws are not rebuilt)."""
        new = self._copy()
        new.commands = np.array(commands, dtype=np.float64)
        return new

    def same_inputs(self, other: RobotSystem) -> bool:
        """Whether ``other`` runs under these very laws and commands (the same objects: a
        re-charting keeps them, a new command does not)."""
        return other.laws is self.laws and other.commands is self.commands

    def _copy(self) -> RobotSystem:
        """A shallow copy (what :func:`copy.copy` makes, without its protocol's cost: once per command)."""
        new = RobotSystem.__new__(RobotSystem)
        new.__dict__.update(self.__dict__)
        return new

    def aims(self, times: FloatArray) -> FloatArray:
        """(len(times), motors) the motors' commands at ``times`` [s]: the held commands and
        constants, and the laws evaluated in time."""
        ts = np.asarray(times, dtype=float)
        out = np.empty((len(ts), len(self.laws)))
        for j, law in self._timed:
            out[:, j] = law.arrays(ts, 0.0)[0]
        # the held values in two assignments, ``0.0 +`` as :meth:`Constant.arrays` computes
        # them (a -0.0 command is 0.0)
        out[:, self._commanded] = 0.0 + self.commands[self._commanded]
        out[:, self._constant] = 0.0 + self._constant_values
        return out

    def fun(self, t: float, y: FloatArray) -> FloatArray:
        """``dy/dt`` at ``(t, y)`` (the sampled entries' rates are 0)."""
        rate: FloatArray = self.evaluate(np.asarray(y, dtype=float)[None]).derivative[0]
        return rate

    def run(self, y: FloatArray, R_ref: FloatArray, h: float, aims: FloatArray, *,
            out: RobotEvaluation | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``len(aims)`` fixed steps of ``h`` [s] from ``y`` in the charts ``R_ref`` with the
        motors' commands ``aims`` (steps, motors) in their modes (:func:`.step_loops.run_steps`): ``(y, R_ref,
        y_end)`` after them (new arrays; ``y_end`` the last step's end before its sampled
        update, in that step's charts). The final ``y`` in the final charts is evaluated into
        ``out`` (from :func:`empty_evaluation` with ``B = 1``; default: arrays thrown away), the
        same numbers as :meth:`evaluate` of it gives."""
        y_new, R_new = np.array(y, dtype=np.float64, order="C"), np.array(R_ref, dtype=np.float64, order="C")
        y_end = np.empty_like(y_new)
        ev = empty_evaluation(self.plan, 1) if out is None else out
        self._steps.run_steps(*self.plan, y_new, R_new, float(h), _arg(aims), self.modes, y_end, ev.derivative,
                               ev.positions, ev.velocities, ev.rotations, ev.forces, ev.rest_lengths, ev.lengths,
                               ev.rates, ev.tensions, ev.depth, ev.normal, ev.friction, ev.couple, **self._options)
        return y_new, R_new, y_end

    def evaluate(self, y: FloatArray, R_ref: FloatArray | None = None, *,
                 out: RobotEvaluation | None = None) -> RobotEvaluation:
        """States ``y`` (B, N) in the charts ``R_ref`` (B, nb, 3, 3; default: this system's),
        written into ``out`` (from :func:`empty_evaluation` with the same ``B``) or new arrays."""
        Y = _arg(np.atleast_2d(y))
        B = len(Y)
        if R_ref is not None:
            R0 = _arg(R_ref)
        elif B == 1:
            R0 = self.R_ref[None]                # a view: R_ref is C-ordered
        else:
            R0 = _arg(np.broadcast_to(self.R_ref, (B,) + self.R_ref.shape))
        ev = empty_evaluation(self.plan, B) if out is None else out
        self._module.evaluate(*self.plan, Y, R0, ev.derivative, ev.positions, ev.velocities, ev.rotations, ev.forces,
                              ev.rest_lengths, ev.lengths, ev.rates, ev.tensions, ev.depth, ev.normal, ev.friction,
                              ev.couple, **self._options)
        return ev


def empty_evaluation(plan: RobotPlan, B: int) -> RobotEvaluation:
    """Uninitialised arrays for the evaluation of ``B`` states (:meth:`RobotSystem.evaluate`):
    consecutive C-ordered pieces of one array, ``block``, so that entries of several
    fields are copied out in one gather (:func:`block_index`)."""
    n, nb, c, ncap = len(plan.base), len(plan.body_dof), len(plan.cable_a), len(plan.cap_node)
    shapes = ((B, plan.n_state), (B, n, 3), (B, n, 3), (B, nb, 3, 3), (B, n, 3), (B, c), (B, c), (B, c), (B, c),
              (B, ncap), (B, ncap), (B, ncap, 3), (B, ncap, 3))
    sizes = [math.prod(s) for s in shapes]
    ends = np.cumsum(sizes)
    block = np.empty(int(ends[-1]))
    d, x, v, R, f, l0, lengths, rates, tensions, depth, normal, friction, couple = (
        block[end - size:end].reshape(shape) for shape, size, end in zip(shapes, sizes, ends))
    return RobotEvaluation(d, x, v, R, f, l0, lengths, rates, tensions, depth, normal, friction, couple, block)


def block_index(plan: RobotPlan, picks: Sequence[tuple[str, ArrayLike]]) -> NDArray[np.intp]:
    """Where in the ``block`` of an evaluation of one state (``B = 1``) the entries
    ``picks`` lie: per ``(field, index)`` the entries ``index`` of that field's array without
    its batch axis, flattened (a node ``k``'s coordinates: ``3 k + (0, 1, 2)``), in turn.
    ``ev.block.take(block_index(plan, picks))`` copies them all in one call."""
    where = empty_evaluation(plan, 1)
    where.block[:] = np.arange(len(where.block))     # each entry its own place (exact in float64)
    taken = [getattr(where, name)[0].ravel()[np.asarray(index, dtype=np.intp)] for name, index in picks]
    return np.concatenate([np.zeros(0), *taken]).astype(np.intp)
