"""RK4 steps of a general model without moving bodies in flat buffers: the fewest numpy calls.

The numpy kernels' cost on a structure of up to a few hundred members is the number of numpy
calls (each costs about 0.5-1 us of dispatch whatever its length), not their arithmetic.
:class:`~.array_stages.ArrayStages` evaluates each RK4 stage through the general
right-hand side, about 20 calls. For a model whose nodes are all free or fixed (no moving
rigid body) and whose members need no slack test inside a step (the stepper's stretches:
a taut string carries compression, a slack one has no stiffness), this module evaluates a
stage in 8 or 9 calls (up to ~100 members) or 12 (larger ones), everything written in place,
each output passed positionally (a keyword ``out=`` costs numpy ~0.1-0.2 us of argument
parsing per call, a fifth to a third of a small call); per stage:

- the member vectors ``h = x_b - x_a``, their lengths ``l = |h|``, the unit vectors
  ``u = h / l`` and ``dy/dt = [v | (external + sum of the member forces on each free
  coordinate) / mass]``;
- the stage states ``y + h sum_j a_ij K_j`` and the step's end as one product of the
  coefficients with the rows ``[y | K_0 .. K_3]`` of one (5, N) array.

While the structure is small (:data:`DENSE_LIMIT` entries of the matrices below) and its state
moves whole nodes (each moving node's three coordinates in turn, one mass per node: every
shipped structure), a stage is eight calls on a *node-major* buffer ``S`` (rows, 3) of one row
per node or member, ``[fixed nodes' x | moving nodes' x | their v | u | (dv . u) u | I_3 | h |
dv]``, whose rows ``x`` and ``v`` are the state itself (so the
state is written in place by its stage product): ``h = C [x_fixed; x]`` with the members'
signed incidence ``C`` (m, n) (at a step's end, and in every stage of a damped model, also
``dv = C_moving v`` with its moving nodes' columns: two products by the incidence's two parts
cost less than one by the block matrix of both from ~50 members), ``l`` the root of the product
of the squared components ``h * h`` by a (3, 3) matrix of ones (each length in its row's three
entries, so every call runs over contiguous (m, 3) arrays), ``u = h / l`` and ``dy/dt`` (as
(2 n_moving, 3): ``[v | a]``) one product of a rate matrix with the rows ``[v | u | (dv . u) u | I_3 | h]`` (above :data:`IDENTITY_LIMIT`, where the
identity rows that carry ``v`` would cost more than a call, ``a`` alone from ``[u | ... | h]``
and ``v`` copied: nine calls). The force of a member on its node
``a``, ``t u`` with ``t = EA (l - l0) / l0 [+ c (dv . u)]``, is written ``k h - EA u [+ c
(dv . u) u]`` (``k = EA / l0`` [N/m]): linear in ``h``, ``u`` and ``(dv . u) u``, whose
coefficients (with the masses' inverses and the signs) are the rate matrix's columns; its
three columns of ``I_3`` hold the external forces per mass (``ext_c / mass`` times the row
``e_c``: three columns where a diagonal of the masses' inverses times the forces took one per
moving node). The
products are BLAS products of matrices of a few hundred to a few thousand entries by three
columns: one call each, and about ``3 m n`` multiplications (a product of component-major
arrays by the whole signed incidence of every coordinate would be nine times that). Above that
size, or when a node is partly fixed or has a mass per axis, the maps are gathers with index
arrays on a flat buffer ``[y | drawn coordinates | external forces on the free coordinates | 0
| forces on the nodes a | their opposites]`` (both ends of every member, and every
coordinate's terms summed row by row and scaled), the force as ``q h`` with ``q = t / l = k -
EA / l`` (and ``-q h`` on the nodes ``b``).

The formulas are those of :mod:`.loops`, member by member, the sums in another order: the
numbers agree with the compiled kernels to rounding (the split ``k h - EA u`` adds two terms
of the size of ``EA`` where the loops add one of the size of ``t``: an absolute rounding of a
few ``eps EA`` [N] per member in both; the lengths are the loops' roots of sums of squares, the
sums in BLAS's order). The screen for a string's slack/taut event
decides as :func:`.loops.quiet_step`, so a stretch stops where the compiled one does, from
the gaps signed by their signs at the stretch's start (:func:`quiet_ends`): one reduction
per step's end gives the least signed gap and the largest rate.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels.array_stages import hermite
from tensegrity_core.sim.general.kernels.flat_layout import FlatLayout
from tensegrity_core.sim.general.kernels.plan import Plan
from tensegrity_core.sim.integrators import Run

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Largest number of entries of the node-major matrices (incidence and rates,
#: :meth:`.FlatLayout.dense_entries`) for which the maps are dense products; above it, gathers
#: (the measured crossover, docs/design/performance.md: dense faster on 99 members, gathers on 198).
DENSE_LIMIT = 40_000
#: Largest number of entries of the identity rows that let the rate product carry the velocities
#: into ``dx/dt`` (``n_moving x`` the product's columns): below it they cost less than a copy
#: (one call), above it more (measured: a tie on 45 members, the copy 48 against 53-54 us per
#: step on 99; docs/design/performance.md).
IDENTITY_LIMIT = 2_000
#: The quiet-step screen's factor (:func:`.loops.quiet_step`: a cubic between its ends strays
#: at most 4/27 of the step times the sum of its end slopes), with its rounding margin.
SCREEN = (4.0 / 27.0) * (1.0 + 1e-9)
#: ``np.dot`` and ``np.copyto`` without numpy's ``__array_function__`` dispatch (NEP 18's
#: ``_implementation``, the C function itself): the dispatch costs 0.2-0.5 us per call, as much
#: as a product of the small matrices here; every array here is a plain ndarray. A numpy
#: without the attribute gives the dispatching functions: the same numbers, a little slower.
DOT: Callable[..., Any] = getattr(np.dot, "_implementation", np.dot)
COPYTO: Callable[..., Any] = getattr(np.copyto, "_implementation", np.copyto)
#: (3, 3) ones: a row of squared components times it is the row's sum in each of its three
#: entries, so the lengths and unit vectors are products and ufuncs over contiguous (m, 3)
#: arrays (two ``hypot`` of strided columns and a division broadcasting the lengths along rows
#: of three cost 1.5-1.8x as much from 45 members: the ufuncs' inner loops run three entries long).
SUMS = np.ones((3, 3))
#: The fractions of the step at RK4's stages 1-3.
FRACTIONS = (0.5, 0.5, 1.0)


def flat_ready(plan: Plan) -> bool:
    """Whether :class:`FlatStages` can step ``plan``: no moving body, no member that goes
    slack by its length inside a step."""
    return not len(plan.body_dof) and not bool(np.any(plan.is_string))


def rk4_coefficients(h: float) -> FloatArray:
    """(4, 5): per RK4 stage 1-3 and the step's end, the weights of ``[y, K_0, .., K_3]``."""
    c = np.zeros((4, 5))
    c[:, 0] = 1.0
    c[0, 1], c[1, 2], c[2, 3] = 0.5 * h, 0.5 * h, h
    c[3, 1:] = h * np.array([1.0, 2.0, 2.0, 1.0]) / 6.0
    return c


def quiet_ends(E0: FloatArray, E1: FloatArray, least0: float, most0: float, least1: float, most1: float,
               h: float) -> bool:
    """:func:`.loops.quiet_step` of a step of ``h`` [s] within a stretch, from its ends ``E0``,
    ``E1`` (3, m) of :meth:`FlatStages._gaps`: per member its gap ``l - l0`` [m] times the
    gap's sign at the stretch's start, its rate [m/s] and the rate's opposite; ``least`` the
    least signed gap and ``most`` the largest rate magnitude of each end. No gap changes sign
    and none comes nearer zero than 4/27 h (|rate_0| + |rate_1|).

    Every step before this one in the stretch kept its gaps' signs, so a gap keeps its sign
    in this one exactly when its signed gap at the end is positive (the loops' ``g0 g1 > 0``;
    a gap zero at the stretch's start has sign 0 and stops the first step): the least signed
    gap decides, and the signed gaps are the gaps' magnitudes. Then the least gaps and the
    largest rates decide at once when they suffice (they imply the member-by-member test:
    rounding is monotone), else member by member. (The loops' product of two gaps underflows
    to zero below 1e-154 m, which stops their step and not this one: no length is that exact.)"""
    if not least1 > 0.0:
        return False
    if min(least0, least1) >= SCREEN * h * (most0 + most1):
        return True
    margin = np.add(np.maximum(E0[1], E0[2]), np.maximum(E1[1], E1[2]))
    margin *= SCREEN * h
    return not bool(np.any(np.minimum(E0[0], E1[0]) < margin))


def _dense_rate(C: FloatArray, C_moving: FloatArray, P: FloatArray, H: FloatArray, squares: FloatArray,
                L: FloatArray, U: FloatArray, R: FloatArray, tail: FloatArray, V: FloatArray, dv: FloatArray,
                rates: FloatArray, DU: FloatArray, damped: bool, velocities: bool,
                identity: bool) -> Callable[[tuple[FloatArray, FloatArray, FloatArray]], None]:
    """:meth:`FlatStages._rate` with the node-major maps, its arrays bound in a closure (no
    attribute look-ups or arguments per call) and every output passed positionally; its
    output is the rate as the views ``(dy/dt (2 n_moving, 3), dx/dt, dv/dt (n_moving, 3))`` of
    :meth:`FlatStages._shaped`. ``identity``: ``R`` carries ``v`` into ``dx/dt`` (its identity
    rows), else ``R`` gives ``dv/dt`` and ``v`` is copied. ``velocities``: the members' velocity differences
    too (``dv = C_moving v``, a second product), into ``dv``. ``L`` (m, 3): each member's length
    [m] in its three entries, from its squared components ``squares`` (m, 3) [m^2]; ``rates``
    (m, 3) (damped) likewise each member's ``dv . u`` [m/s]."""
    dot, sqrt, divide, multiply, copyto = DOT, np.sqrt, np.divide, np.multiply, COPYTO

    def rate_into(out: tuple[FloatArray, FloatArray, FloatArray]) -> None:
        dot(C, P, H)                                # h = x_b - x_a (m, 3)
        if velocities:
            dot(C_moving, V, dv)                    # dv = v_b - v_a (m, 3)
        multiply(H, H, squares)
        dot(squares, SUMS, L)                       # |h|^2 in each of a row's entries
        sqrt(L, L)
        divide(H, L, U)
        if damped:
            multiply(dv, U, DU)
            dot(DU, SUMS, rates)                    # dv . u in each of a row's entries
            multiply(U, rates, DU)
        if identity:
            dot(R, tail, out[0])                    # [v | external / mass + (k h - EA u + c (dv . u) u) / mass]
        else:
            copyto(out[1], V)
            dot(R, tail, out[2])

    return rate_into


def _gathered_rate(stages: FlatStages, out: FloatArray) -> None:
    """:meth:`FlatStages._rate` with gathers."""
    h, l, q, forces = stages.h, stages.lengths, stages._q, stages._forces      # q: t / l (m,) [N/m]
    ends = stages._ends
    stages._sources.take(stages.layout.ends, None, ends, "clip")     # indices valid: no checks
    np.subtract(ends[1], ends[0], h)
    _dot_components(h, h, l, stages._product)
    np.sqrt(l, l)
    np.divide(stages.plan.EA, l, q)                 # t / l = k (l - l0) / l = k - EA / l
    np.subtract(stages._k, q, q)
    if stages.damped:                               # + c (dv . u) / l = c (dv . h) / l^2
        w = stages.rate
        stages._velocity_differences()
        _dot_components(stages.dv, h, w, stages._product)
        w *= stages.plan.damping
        w /= l
        w /= l
        q += w
    np.multiply(h, q, forces[0])                    # on the nodes a; their opposites on the nodes b
    np.negative(forces[0], forces[1])
    n_free = stages.layout.n_free
    out[:n_free] = stages._velocities
    stages.S.take(stages._force_terms, None, stages._terms, "clip")
    acceleration = out[n_free:]
    np.add.reduce(stages._terms, axis=0, out=acceleration)
    acceleration *= stages.plan.free_inv_mass


def _dot_components(a: FloatArray, b: FloatArray, out: FloatArray, work: FloatArray) -> None:
    """``out`` (m,) = per member the dot product of ``a`` and ``b`` (3, m): a product and a sum
    over the components, each one pass over all members (``np.vecdot`` loops member by member:
    2.5x slower from a few hundred members); ``work`` (3, m)."""
    np.multiply(a, b, work)
    np.add.reduce(work, axis=0, out=out)


class FlatStages:
    """RK4 steps of the model of ``plan`` (:func:`flat_ready`) in flat buffers (module
    docstring), with rest lengths ``rest_lengths(t)`` [m] (``constant``: they do not depend
    on ``t``); ``dense``: the linear maps as node-major dense matrices (None: by size and
    layout); ``identity``: (dense) the rate product carries the velocities into ``dx/dt``, else
    they are copied (None: by size, :data:`IDENTITY_LIMIT`); ``layout``: the
    plan's :class:`FlatLayout` if built (one per topology, masses and loads: the plans of
    one model's slack sets share it). A stretch stops at a step that may hold an event of
    the strings ``strings`` (member indices; ``moving``: per string, its rest length moves
    with an input); there is no body to re-chart."""

    #: The methods whose steps this computes (the stepper runs others as scipy's).
    methods = ("RK4",)

    def __init__(self, plan: Plan, rest_lengths: Callable[[float], FloatArray], constant: bool, *,
                 strings: IntArray, moving: NDArray[np.bool_], dense: bool | None = None,
                 identity: bool | None = None, layout: FlatLayout | None = None):
        assert flat_ready(plan), "the flat stages take models without moving bodies or slack tests"
        self.plan, self.rest_lengths, self.constant = plan, rest_lengths, constant
        self.strings, self.moving = strings, moving
        self.damped = bool(np.any(plan.damping))
        lay = FlatLayout(plan) if layout is None else layout
        whole = lay.moving is not None
        self.dense = (whole and lay.dense_entries() <= DENSE_LIMIT) if dense is None else dense
        assert whole or not self.dense, "the node-major maps need a state of whole nodes (flat_layout.whole_nodes)"
        m, m3, N = lay.n_members, 3 * lay.n_members, lay.n_state
        self.lengths, self.rate = np.empty(m), np.empty(m)
        self.S: FloatArray
        #: the rate of the state in ``S`` into an output of :meth:`_shaped`: at a stage, at a step's end
        self._rate_into: Callable[[Any], None]
        self._rate_end: Callable[[Any], None]
        if self.dense:
            C, moving_part, self._pull, inverse_mass, x_fixed, external = lay.node_maps()
            nf, nm, du = len(x_fixed), len(inverse_mass), m if self.damped else 0
            # S (rows, 3) = [x fixed (nf) | x (nm) | v (nm) | u (m) | (dv . u) u (du) | I_3 (3) | h (m) | dv (m)]
            x, v = nf + nm, nf + 2 * nm
            u, e, h = v + m, v + m + du, v + m + du + 3
            self.S = np.zeros((h + 2 * m, 3))
            self.S[:nf], self.S[e:h] = x_fixed, np.eye(3)
            self.u, self._du, self.h, self.dv = self.S[v:u], self.S[u:e], self.S[h:h + m], self.S[h + m:]
            # accelerations (nm, 3) = A [u | (dv . u) u | I_3 | h], the columns of h k's (_rest);
            # R = A, or (small) [[I, 0], [0, A]] for [v | a] = R [v | u | ...] in the same product
            self._identity = nm * (nm + 2 * m + du + 3) <= IDENTITY_LIMIT if identity is None else identity
            rows = 2 * nm if self._identity else nm
            self._R = R = np.zeros((rows, rows - nm + 2 * m + du + 3))
            R[:rows - nm, :rows - nm] = np.eye(rows - nm)
            A = R[rows - nm:, rows - nm:]
            A[:, :m] = self._pull * -plan.EA
            if self.damped:
                A[:, m:2 * m] = self._pull * plan.damping
            A[:, m + du:m + du + 3] = external * inverse_mass[:, None]
            self._k_columns = A[:, m + du + 3:]
            self._state = self.S.reshape(-1)[3 * nf:3 * nf + N]
            self._C, self._positions, self._tail = C, self.S[:x], self.S[v - (rows - nm):h + m]
            squares, L = np.empty((m, 3)), np.empty((m, 3))
            self.lengths = L[:, 0]
            rates = [_dense_rate(C, moving_part, self._positions, self.h, squares, L, self.u, R, self._tail,
                                 self.S[x:v], self.dv, np.empty((m, 3)), self._du, self.damped, velocities,
                                 self._identity)
                     for velocities in (self.damped, True)]
            self._rate_into, self._rate_end = rates
        else:
            src = lay.sources
            # S = [sources | forces on the nodes a (3m) | their opposites (3m)]
            self.S = np.zeros(src + 2 * m3)
            self.h, self.dv = np.empty((3, m)), np.empty((3, m))
            self._forces = self.S[src:].reshape(2, 3, m)
            self._q = np.empty(m)
            self._ends, self._product = np.empty((2, 3, m)), np.empty((3, m))
            self._force_terms = np.ascontiguousarray(lay.terms[:, lay.n_free:])     # v's rows only
            self._terms = np.empty(self._force_terms.shape)
            self.S[N:src] = lay.constants
            self._state, self._sources, self._velocities = self.S[:N], self.S[:src], self.S[N // 2:N]
            self._rate_into = self._rate_end = partial(_gathered_rate, self)
        self.layout = lay
        self._k = np.empty(m)
        self._Z = (np.empty((5, N)), np.empty((5, N)))      # [y, K_0 .. K_3] of this step and the next
        #: per buffer of ``_Z``: per stage 1-3 the rows ``[y, K_0 .. K_j]`` it combines and its rate's
        #: row (shaped as the rate's output); then its rows ``y`` and ``K_0`` (shaped)
        self._stages = tuple(tuple((Z[:j + 2], self._shaped(Z[j + 2])) for j in range(3)) for Z in self._Z)
        self._heads = tuple((Z[0], self._shaped(Z[1])) for Z in self._Z)
        self._h: float | None = None
        self._weights: list[FloatArray] = []

    def _rest(self, l0: FloatArray) -> None:
        """Rest lengths ``l0`` [m] for the next evaluations, with ``k = EA / l0`` [N/m] and
        (dense) the rate matrix's columns of ``h``."""
        np.divide(self.plan.EA, l0, out=self._k)
        if self.dense:
            np.multiply(self._pull, self._k, self._k_columns)                                    # k h

    def _rate(self, out: FloatArray) -> None:
        """``out`` (N,) = ``dy/dt`` of the state in ``S`` (rest lengths of :meth:`_rest`); its
        member vectors [m] and lengths [m] are left in ``self.h`` and ``self.lengths``, and
        (dense) the velocity differences [m/s] in ``self.dv``."""
        self._rate_end(self._shaped(out))

    def _shaped(self, rate: FloatArray) -> Any:
        """A rate (N,) as the rate's closures write it: the views ``(dy/dt (2 n_moving, 3),
        dx/dt, dv/dt (n_moving, 3))`` (dense), itself (gathers)."""
        if not self.dense:
            return rate
        half = len(rate) // 2
        return rate.reshape(-1, 3), rate[:half].reshape(-1, 3), rate[half:].reshape(-1, 3)

    def _velocity_differences(self) -> None:
        """(gathers) ``self.dv`` (3, m): ``v_b - v_a`` of the members at the state in ``S``."""
        self._sources.take(self.layout.velocity_ends, None, self._ends, "clip")
        np.subtract(self._ends[1], self._ends[0], self.dv)

    def _step_of(self, h: float) -> None:
        """The weights of :func:`rk4_coefficients` for steps of ``h`` [s] in ``self._weights``."""
        if h != self._h:
            c = rk4_coefficients(h)
            self._h, self._weights = h, [c[j, :j + 2] for j in range(3)] + [c[3]]

    def _step(self, t: float, h: float, Z: FloatArray, Z_next: FloatArray, varying: bool) -> None:
        """One RK4 step of ``h`` [s] from ``(t, Z[0])`` (rate ``Z[1]``): its stages in ``Z[2:]``,
        the new state in ``Z_next[0]`` and its rate in ``Z_next[1]``; ``varying``: the rest
        lengths at each stage from ``rest_lengths``, else those of the last :meth:`_rest`."""
        self._step_of(h)
        w, state, rate, dot = self._weights, self._state, self._rate_into, DOT
        for j, (rows, K) in enumerate(self._stages[Z is self._Z[1]]):     # stage j + 1 at y + c h K_j
            dot(w[j], rows, state)
            if varying:
                self._rest(self.rest_lengths(t + FRACTIONS[j] * h))
            rate(K)
        y_new, f_new = self._heads[Z_next is self._Z[1]]
        dot(w[3], Z, y_new)
        state[...] = y_new
        if varying:
            self._rest(self.rest_lengths(t + h))
        self._rate_end(f_new)

    def rk4(self, t: float, y: FloatArray, f: FloatArray, h: float) -> tuple[FloatArray, FloatArray]:
        Z, Z_next = self._Z
        Z[0], Z[1] = y, f
        self._step(t, h, Z, Z_next, True)
        return Z_next[0].copy(), Z_next[1].copy()

    def _screen(self, l0_screen: FloatArray,
                sign: FloatArray) -> Callable[[tuple[FloatArray, ...]], tuple[float, float]]:
        """``gaps(out)``: per member of the last evaluation into ``out = (E, *E)``, an array
        ``E`` (3, m) and its rows (unpacked once: unpacking an array makes its row views anew,
        ~0.6 us), its gap ``l - l0_screen`` [m] times ``sign`` (``+inf`` for members not
        screened: ``l0_screen`` is ``-inf``), the gap's rate [m/s] and the rate's opposite;
        returns the least signed gap and the largest rate magnitude (one reduction; +inf and 0
        without members). :func:`quiet_ends` reads ``E``. A closure over the arrays, as the
        rate's."""
        lengths, dv, subtract, multiply, negative = self.lengths, self.dv, np.subtract, np.multiply, np.negative
        least: Any = np.minimum.reduce          # called with positional arguments (numpy's stubs: keywords)
        if self.dense:
            u, dot, products, ones = self.u, DOT, np.empty(self.u.shape), np.ones(3)

            def rates(rate: FloatArray) -> None:    # dv: the evaluation's (_rate_end)
                multiply(dv, u, products)
                dot(products, ones, rate)           # np.vecdot's rows of three: 1.5-1.8x as long from 45 members
        else:
            def rates(rate: FloatArray) -> None:
                self._velocity_differences()
                _dot_components(dv, self.h, rate, self._product)
                np.divide(rate, lengths, rate)

        def gaps(out: tuple[FloatArray, ...]) -> tuple[float, float]:
            E, gap, rate, opposite = out
            subtract(lengths, l0_screen, gap)
            multiply(gap, sign, gap)
            rates(rate)
            negative(rate, opposite)
            low_gap, low, high = least(E, 1, None, None, False, np.inf).tolist()
            return low_gap, -min(low, high, 0.0)

        return gaps

    def rk4_run(self, t: float, y: FloatArray, f: FloatArray, h_fixed: float, t_bound: float, horizon: float,
                samples: FloatArray, sample: int) -> Run:
        """:meth:`.array_stages.ArrayStages.rk4_run` in flat buffers: RK4 steps of ``h_fixed``
        [s] from ``(t, y)`` (rate ``f``) as far as ``horizon`` [s] or a step that may hold an
        event, with the states at ``samples[sample:]`` [s] that the steps before the last one
        cover; constant rest lengths only."""
        assert self.constant, "a stretch of steps needs constant rest lengths"
        l0 = self.rest_lengths(t)
        # the members screened: strings whose rest length no input moves (the others never stop a step)
        screened = self.strings[~self.moving]
        l0_screen = np.full(len(l0), -np.inf)
        l0_screen[screened] = l0[screened]
        Y = np.empty((len(samples), len(y)))
        Z, Z_next = self._Z
        Z[0], Z[1] = y, f
        self._state[...] = y
        self._rest(l0)
        self._rate(np.empty_like(y))
        sign = np.sign(self.lengths - l0_screen)          # the gaps' signs at the stretch's start
        E, E_next = ((A, *A) for A in (np.empty((3, len(l0))), np.empty((3, len(l0)))))    # a step's ends: _screen
        gaps = self._screen(l0_screen, sign)
        least0, most0 = gaps(E)
        self._step_of(h_fixed)
        w1, w2, w3, w4 = self._weights
        rate, rate_end, dot, state, stages = self._rate_into, self._rate_end, DOT, self._state, self._stages
        #: per parity of the step: its stages' rows and rate outputs, its buffer and the next one's heads
        ends = tuple((*(x for pair in stages[k] for x in pair), self._Z[k], *self._heads[1 - k]) for k in (0, 1))
        odd, limit, stop = 0, h_fixed * (1.0 + 1e-9), min(horizon, t_bound)
        steps = 0
        due = samples[sample] if sample < len(samples) else np.inf       # the next sample's time [s]
        while True:
            left = t_bound - t
            if left < limit:                                # the last step, to the bound
                h = left
                self._step(t, h, Z, Z_next, False)
                t_new = t_bound
            else:
                h = h_fixed
                rows1, K1, rows2, K2, rows3, K3, Z, y_new, f_new = ends[odd]
                dot(w1, rows1, state)
                rate(K1)
                dot(w2, rows2, state)
                rate(K2)
                dot(w3, rows3, state)
                rate(K3)
                dot(w4, Z, y_new)
                state[...] = y_new
                rate_end(f_new)
                t_new = t + h
            steps += 1
            least1, most1 = gaps(E_next)
            if t_new >= stop or not quiet_ends(E[0], E_next[0], least0, most0, least1, most1, t_new - t):
                return Run(steps, steps, t, Z[0].copy(), Z[1].copy(), t_new, Z_next[0].copy(), Z_next[1].copy(),
                           sampled=sample, Y=Y)
            if due <= t_new:
                end = int(np.searchsorted(samples, t_new, side="right"))
                if end == sample + 1 and due == t_new:
                    Y[sample] = Z_next[0]
                else:
                    Y[sample:end] = hermite(Z[0], Z[1], Z_next[0], Z_next[1], t_new - t,
                                            (samples[sample:end] - t) / (t_new - t))
                sample = end
                due = samples[sample] if sample < len(samples) else np.inf
            t, Z, Z_next, E, E_next, least0, most0, odd = t_new, Z_next, Z, E_next, E, least1, most1, 1 - odd
