"""RK4 steps of a general model without moving bodies in flat buffers: the fewest numpy calls.

The numpy kernels' cost on a structure of up to a few hundred members is the number of numpy
calls (each costs about 0.5-1 us of dispatch whatever its length), not their arithmetic.
:class:`~.array_stages.ArrayStages` evaluates each RK4 stage through the general
right-hand side, about 20 calls. For a model whose nodes are all free or fixed (no moving
rigid body) and whose members need no slack test inside a step (the stepper's stretches:
a taut string carries compression, a slack one has no stiffness), this module evaluates a
stage in 6 calls (small models) or 12 (larger ones), everything written in place, each
output passed positionally (a keyword ``out=`` costs numpy ~0.1-0.2 us of argument parsing
per call, a fifth to a third of a small call):

- a flat *source* buffer ``S = [y (N) | drawn coordinates (3n) | external forces on the free
  coordinates (n_free) | 0 | ...]`` whose tail holds the members' quantities (below);
- the member vectors ``h = x_b - x_a`` (3, m, component-major) as one linear map of ``S``;
- ``l = |h|``: ``hypot(hypot(h_x, h_y), h_z)`` for the dense maps (two calls on a few
  dozen members, against a dot product per member and a root), a product, a sum over the
  components and a root for the gathers (``hypot`` costs more per member);
- ``dy/dt = [v | (external + sum of the member forces on each free coordinate) / mass]``
  as one linear map of ``S``;
- the stage states ``y + h sum_j a_ij K_j`` and the step's end as one product of the
  coefficients with the rows ``[y | K_0 .. K_3]`` of one (5, N) array.

The linear maps are dense matrices while they are small (:data:`DENSE_LIMIT` entries): one
BLAS product whatever the number of nonzeros. Then the force of a member on its node ``a``,
``t u`` with ``t = EA (l - l0) / l0 [+ c (dv . u)]``, is written ``k h - EA u [+ c (dv . u)
u]`` (``k = EA / l0`` [N/m], ``u = h / l``): linear in ``h``, ``u`` and ``(dv . u) u``, whose
coefficients (with the masses' inverses and the signs) are the rate matrix's columns, so a
stage is ``h, dv = G S``; ``l`` (two calls); ``u = h / l``; ``dy/dt = D S``. Above that size a dense
product's work exceeds the calls it saves: the maps are gathers with index arrays (both ends
of every member, and every coordinate's terms summed row by row and scaled), the force as
``q h`` with ``q = t / l = k - EA / l`` (and ``-q h`` on the nodes ``b``).

The formulas are those of :mod:`.loops`, member by member, the sums in another order: the
numbers agree with the compiled kernels to rounding (the split ``k h - EA u`` adds two terms
of the size of ``EA`` where the loops add one of the size of ``t``: an absolute rounding of a
few ``eps EA`` [N] per member in both; ``hypot`` rounds a length once where the loops'
root of a sum rounds it up to three times). The screen for a string's slack/taut event
decides as :func:`.loops.quiet_step`, so a stretch stops where the compiled one does, from
the gaps signed by their signs at the stretch's start (:func:`quiet_ends`): one reduction
per step's end gives the least signed gap and the largest rate.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cached_property, partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels.array_stages import hermite
from tensegrity_core.sim.general.kernels.plan import Plan
from tensegrity_core.sim.integrators import Run

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Largest number of entries of the two dense matrices (member vectors and rates) for which
#: the linear maps are dense products; above it, gathers (the measured crossover,
#: docs/design/performance.md: dense faster up to ~27 members, gathers from ~36).
DENSE_LIMIT = 50_000
#: The quiet-step screen's factor (:func:`.loops.quiet_step`: a cubic between its ends strays
#: at most 4/27 of the step times the sum of its end slopes), with its rounding margin.
SCREEN = (4.0 / 27.0) * (1.0 + 1e-9)
#: ``np.vecdot``'s axes for a dot product over the components of (3, m) arrays: one per member
#: (untyped: numpy's stubs type a gufunc's ``axes`` as matmul's pairs). One call, the cheapest
#: below ~50 members (the dense maps' sizes); it loops member by member.
COMPONENTS: Any = [(0,), (0,), ()]
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


def _dense_rate(G: FloatArray, D: FloatArray, S: FloatArray, sources: FloatArray, hv: FloatArray, h: FloatArray,
                l: FloatArray, u: FloatArray, dv: FloatArray, rate: FloatArray, du: FloatArray,
                damped: bool) -> Callable[[FloatArray], None]:
    """:meth:`FlatStages._rate` with dense maps, its arrays bound in a closure (no attribute
    look-ups or arguments per call) and every output passed positionally."""
    dot, hypot, divide = np.dot, np.hypot, np.divide
    hx, hy, hz = h

    def rate_into(out: FloatArray) -> None:
        dot(G, sources, hv)                         # h, dv
        hypot(hx, hy, l)
        hypot(l, hz, l)
        divide(h, l, u)
        if damped:
            np.vecdot(dv, u, axes=COMPONENTS, out=rate)
            np.multiply(u, rate, du)
        dot(D, S, out)                              # v; (external + k h - EA u + c (dv . u) u) / mass

    return rate_into


def _gathered_rate(stages: FlatStages, out: FloatArray) -> None:
    """:meth:`FlatStages._rate` with gathers."""
    h, l, Q = stages.h, stages.lengths, stages._Q     # Q: [t / l, -t / l] (2, m) [N/m]
    ends = stages._ends
    stages._sources.take(stages.layout.ends, None, ends, "clip")     # indices valid: no checks
    np.subtract(ends[1], ends[0], h)
    _dot_components(h, h, l, stages._product)
    np.sqrt(l, l)
    np.divide(stages._EA2, l, Q)                    # t / l = k (l - l0) / l = k - EA / l
    np.subtract(stages._k2, Q, Q)
    if stages.damped:                               # + c (dv . u) / l = c (dv . h) / l^2
        w = stages.rate
        stages._velocity_differences()
        _dot_components(stages.dv, h, w, stages._product)
        w *= stages.plan.damping
        w /= l
        w /= l
        Q[0] += w
        Q[1] -= w
    np.multiply(h, Q[:, None, :], stages._forces)
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


class FlatLayout:
    """The index arrays of the flat buffer of ``plan`` (module docstring).

    Sources ``S[:sources]``: ``y``, the drawn coordinates, the external forces on the free
    coordinates, a zero. ``ends`` (2, 3, m): per member end (a, b), component and member, the
    entry of the sources giving that node coordinate (a free one its ``x``, a fixed one its
    drawn value); ``velocity_ends`` likewise for velocities (a fixed coordinate: the zero).
    ``terms`` (d, N): per entry of ``dy/dt`` the entries it sums, padded with the zero: for
    ``x`` its ``v``; for ``v`` its external force, then per member in member order the
    member's force on it, an entry of the (2, 3, m) block ``[+force on a | -force on b]``
    right after the sources; ``scale`` (N,) the factor of each sum (1 for ``x``, the
    inverse mass for ``v``)."""

    def __init__(self, plan: Plan):
        n, m, n_free = plan.n_nodes, len(plan.member_a), len(plan.free_node)
        N = 2 * n_free
        self.n_state, self.n_members, self.n_free = N, m, n_free
        external = N + 3 * n
        self.zero = external + n_free
        self.sources = self.zero + 1
        position = N + 3 * np.arange(n)[:, None] + np.arange(3)
        velocity = np.full((n, 3), self.zero, dtype=np.int64)
        position[plan.free_node, plan.free_axis] = np.arange(n_free)
        velocity[plan.free_node, plan.free_axis] = n_free + np.arange(n_free)
        a, b = plan.member_a, plan.member_b
        self.ends = np.ascontiguousarray(np.stack([position[a].T, position[b].T]), dtype=np.int64)
        self.velocity_ends = np.ascontiguousarray(np.stack([velocity[a].T, velocity[b].T]), dtype=np.int64)
        tail = self.sources
        coordinate = np.full((n, 3), -1, dtype=np.int64)
        coordinate[plan.free_node, plan.free_axis] = np.arange(n_free)
        lists: list[list[int]] = [[external + j] for j in range(n_free)]
        for i in range(m):                        # member order, as the loops add the forces
            for k in range(3):
                for node, side in ((a[i], 0), (b[i], 1)):
                    j = coordinate[node, k]
                    if j >= 0:
                        lists[j].append(tail + side * 3 * m + k * m + i)
        self.terms = np.full((max([1] + [len(t) for t in lists]), N), self.zero, dtype=np.int64)
        self.terms[0, :n_free] = n_free + np.arange(n_free)
        for j, t in enumerate(lists):
            self.terms[:len(t), n_free + j] = t
        self.scale = np.concatenate([np.ones(n_free), plan.free_inv_mass])
        self.constants = np.concatenate([np.asarray(plan.base, dtype=float).ravel(),
                                         plan.external[plan.free_node, plan.free_axis], [0.0]])

    @cached_property
    def _dense(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        G = np.concatenate([self.difference_matrix(self.ends), self.difference_matrix(self.velocity_ends)])
        return (G, *self.force_matrix())

    def dense_maps(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(built on first use, kept: do not modify) the member vectors and velocities
        (6m, sources) of :meth:`difference_matrix` and the two parts of :meth:`force_matrix`."""
        return self._dense

    def dense_entries(self) -> int:
        """Entries of the dense matrices: member vectors and velocities (6m, sources), rates
        (N, sources + 12m)."""
        m = self.n_members
        return 6 * m * self.sources + self.n_state * (self.sources + 12 * m)

    def difference_matrix(self, ends: IntArray) -> FloatArray:
        """(3m, sources): the differences ``S[ends[1]] - S[ends[0]]`` as a matrix."""
        G = np.zeros((3 * self.n_members, self.sources))
        rows = np.arange(3 * self.n_members)
        np.add.at(G, (rows, ends[1].ravel()), 1.0)
        np.add.at(G, (rows, ends[0].ravel()), -1.0)
        G[:, self.zero] = 0.0
        return G

    def force_matrix(self) -> tuple[FloatArray, FloatArray]:
        """``(D0, incidence)``: ``D0`` (N, sources) ``dy/dt`` from the sources alone (``x``'s
        rate, the external forces scaled); ``incidence`` (N, 3m) the scaled signed incidence:
        ``dy/dt += incidence @ f`` for member forces ``f`` (3, m) on the nodes ``a``."""
        m3 = 3 * self.n_members
        D = np.zeros((self.n_state, self.sources + 2 * m3))
        cols = np.arange(self.n_state)
        for row in self.terms:
            np.add.at(D, (cols, row), self.scale)
        D[:, self.zero] = 0.0
        incidence = D[:, self.sources:self.sources + m3] - D[:, self.sources + m3:]
        return np.ascontiguousarray(D[:, :self.sources]), incidence


class FlatStages:
    """RK4 steps of the model of ``plan`` (:func:`flat_ready`) in flat buffers (module
    docstring), with rest lengths ``rest_lengths(t)`` [m] (``constant``: they do not depend
    on ``t``); ``dense``: the linear maps as dense matrices (None: by size); ``layout``: the
    plan's :class:`FlatLayout` if built (one per topology, masses and loads: the plans of
    one model's slack sets share it). A stretch stops at a step that may hold an event of
    the strings ``strings`` (member indices; ``moving``: per string, its rest length moves
    with an input); there is no body to re-chart."""

    #: The methods whose steps this computes (the stepper runs others as scipy's).
    methods = ("RK4",)

    def __init__(self, plan: Plan, rest_lengths: Callable[[float], FloatArray], constant: bool, *,
                 strings: IntArray, moving: NDArray[np.bool_], dense: bool | None = None,
                 layout: FlatLayout | None = None):
        assert flat_ready(plan), "the flat stages take models without moving bodies or slack tests"
        self.plan, self.rest_lengths, self.constant = plan, rest_lengths, constant
        self.strings, self.moving = strings, moving
        self.damped = bool(np.any(plan.damping))
        lay = FlatLayout(plan) if layout is None else layout
        self.dense = lay.dense_entries() <= DENSE_LIMIT if dense is None else dense
        m, m3, N, src = lay.n_members, 3 * lay.n_members, lay.n_state, lay.sources
        if self.dense:
            # S = [sources | h (3m) | dv (3m) | u (3m) | (dv . u) u (3m)]
            self.S = np.zeros(src + 4 * m3)
            self._hv = self.S[src:src + 2 * m3]
            self.h, self.dv = (self.S[src + j * m3:src + (j + 1) * m3].reshape(3, m) for j in range(2))
            self.u, self._du = (self.S[src + j * m3:src + (j + 1) * m3].reshape(3, m) for j in (2, 3))
            self._G, D0, self._incidence = lay.dense_maps()
            self._D = np.zeros((N, len(self.S)))
            self._D[:, :src] = D0
        else:
            # S = [sources | forces on the nodes a (3m) | their opposites (3m)]
            self.S = np.zeros(src + 2 * m3)
            self.h, self.dv = np.empty((3, m)), np.empty((3, m))
            self._forces = self.S[src:].reshape(2, 3, m)
            self._Q = np.empty((2, m))
            self._EA2, self._k2 = np.stack([plan.EA, -plan.EA]), np.empty((2, m))
            self._ends, self._product = np.empty((2, 3, m)), np.empty((3, m))
            self._force_terms = np.ascontiguousarray(lay.terms[:, lay.n_free:])     # v's rows only
            self._terms = np.empty(self._force_terms.shape)
        self.layout = lay
        self.S[N:src] = lay.constants
        self._state, self._sources, self._velocities = self.S[:N], self.S[:src], self.S[N // 2:N]
        self.lengths, self.rate = np.empty(m), np.empty(m)
        self._k = np.empty(m)
        self._Z = (np.empty((5, N)), np.empty((5, N)))      # [y, K_0 .. K_3] of this step and the next
        #: per buffer of ``_Z``: per stage 1-3 the rows ``[y, K_0 .. K_j]`` it combines and the row
        #: of its rate; then its rows ``y`` and ``K_0``
        self._stages = tuple(tuple((Z[:j + 2], Z[j + 2]) for j in range(3)) for Z in self._Z)
        self._heads = tuple((Z[0], Z[1]) for Z in self._Z)
        self._h: float | None = None
        self._weights: list[FloatArray] = []
        self._rate_into: Callable[[FloatArray], None] = \
            _dense_rate(self._G, self._D, self.S, self._sources, self._hv, self.h, self.lengths, self.u, self.dv,
                        self.rate, self._du, self.damped) if self.dense else partial(_gathered_rate, self)

    def _rest(self, l0: FloatArray) -> None:
        """Rest lengths ``l0`` [m] for the next evaluations, with ``k = EA / l0`` [N/m] and
        (dense) the rate matrix's member columns."""
        np.divide(self.plan.EA, l0, out=self._k)
        if not self.dense:
            np.stack([self._k, -self._k], out=self._k2)
        else:
            src, m3 = self.layout.sources, 3 * self.layout.n_members
            inc, D = self._incidence, self._D
            np.multiply(inc, np.tile(self._k, 3), out=D[:, src:src + m3])                       # k h
            np.multiply(inc, -np.tile(self.plan.EA, 3), out=D[:, src + 2 * m3:src + 3 * m3])    # -EA u
            np.multiply(inc, np.tile(self.plan.damping, 3), out=D[:, src + 3 * m3:])            # c (dv . u) u

    def _rate(self, out: FloatArray) -> None:
        """``out`` (N,) = ``dy/dt`` of the state in ``S`` (rest lengths of :meth:`_rest`); its
        member vectors [m] and lengths [m] are left in ``self.h`` and ``self.lengths``, and
        (dense) the velocity differences [m/s] in ``self.dv``."""
        self._rate_into(out)

    def _velocity_differences(self) -> None:
        """(gathers) ``self.dv`` (3, m): ``v_b - v_a`` of the members at the state in ``S``."""
        self._sources.take(self.layout.velocity_ends, None, self._ends, "clip")
        np.subtract(self._ends[1], self._ends[0], self.dv)

    def _step(self, t: float, h: float, Z: FloatArray, Z_next: FloatArray, varying: bool) -> None:
        """One RK4 step of ``h`` [s] from ``(t, Z[0])`` (rate ``Z[1]``): its stages in ``Z[2:]``,
        the new state in ``Z_next[0]`` and its rate in ``Z_next[1]``; ``varying``: the rest
        lengths at each stage from ``rest_lengths``, else those of the last :meth:`_rest`."""
        if h != self._h:
            c = rk4_coefficients(h)
            self._h, self._weights = h, [c[j, :j + 2] for j in range(3)] + [c[3]]
        w, state, rate, dot = self._weights, self._state, self._rate_into, np.dot
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
        rate(f_new)

    def rk4(self, t: float, y: FloatArray, f: FloatArray, h: float) -> tuple[FloatArray, FloatArray]:
        Z, Z_next = self._Z
        Z[0], Z[1] = y, f
        self._step(t, h, Z, Z_next, True)
        return Z_next[0].copy(), Z_next[1].copy()

    def _gaps(self, l0_screen: FloatArray, sign: FloatArray, out: FloatArray) -> tuple[float, float]:
        """Per member of the last evaluation into ``out`` (3, m): its gap ``l - l0`` [m] times
        ``sign`` (``+inf`` for members not screened), the gap's rate [m/s] and the rate's
        opposite; returns the least signed gap and the largest rate magnitude (one reduction;
        +inf and 0 without members). :func:`quiet_ends` reads them."""
        gap, rate, opposite = out
        np.subtract(self.lengths, l0_screen, gap)
        np.multiply(gap, sign, gap)
        if self.dense:
            np.vecdot(self.dv, self.u, axes=COMPONENTS, out=rate)
        else:
            self._velocity_differences()
            _dot_components(self.dv, self.h, rate, self._product)
            np.divide(rate, self.lengths, rate)
        np.negative(rate, opposite)
        least, low, high = np.minimum.reduce(out, 1, initial=np.inf).tolist()
        return least, -min(low, high, 0.0)

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
        E, E_next = np.empty((3, len(l0))), np.empty((3, len(l0)))     # a step's ends: _gaps
        least0, most0 = self._gaps(l0_screen, sign, E)
        step, gaps, limit = self._step, self._gaps, h_fixed * (1.0 + 1e-9)
        steps = 0
        due = samples[sample] if sample < len(samples) else np.inf       # the next sample's time [s]
        while True:
            left = t_bound - t
            h = left if left < limit else h_fixed
            step(t, h, Z, Z_next, False)
            t_new = t_bound if h == left else t + h
            steps += 1
            least1, most1 = gaps(l0_screen, sign, E_next)
            if t_new >= horizon or t_new >= t_bound or not quiet_ends(E, E_next, least0, most0, least1, most1,
                                                                      t_new - t):
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
            t, Z, Z_next, E, E_next, least0, most0 = t_new, Z_next, Z, E_next, E, least1, most1
