"""The actuators of the class-2 mechanism: input law, optional first-order lag, optional compliance.

Signal chain of actuator ``i`` (forces in N, tension positive):

1. the input law gives the commanded force ``u_i(t, rho_i)``;
2. with **actuator lag** (time constant ``tau``) the source force is a state ``f_i`` with
   ``df_i/dt = (u_i - f_i) / tau``; without it ``f_i = u_i``;
3. with **actuator compliance** the source drives the mechanism through a stiff spring
   ``k_a`` in series: the drive of length ``x_i`` has viscous loss ``c_d`` (a force source
   with back-EMF damping: its friction resists its own extension and contraction), the
   spring's elongation ``e_i = rho_i - x_i`` is a state and carries ``T_i = k_a e_i``. The
   junction is massless, so the tension is the same along the chain:
   ``T_i = f_i + c_d dx_i/dt``, hence ``de_i/dt = drho_i/dt + (f_i - k_a e_i) / c_d``. Its
   eigenvalue ``-k_a/c_d`` makes the system stiff; for ``k_a -> inf`` the mechanism sees
   ``f_i + c_d drho_i/dt`` (the drive's loss damps the actuator's motion). Without
   compliance ``T_i = f_i``.

``T_i`` is the force the actuator applies to the mechanism (generalised force ``-T_i`` on
``rho_i``). Extra states follow ``q, qdot`` in the state vector: lag forces, then elongations.

:class:`Drive` is the chain's configuration (frozen); the input laws come with each call,
so a changed command is a new set of laws (:meth:`Drive.bind` builds the evaluation path
once per set, with no branches per call).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol, TypeAlias

import numpy as np
from numpy.typing import NDArray


class ForceLaw(Protocol):
    """What the drive reads of an actuator's input law
    (:mod:`tensegrity_core.sim.inputs`): the commanded force [N] at time ``t`` [s] and
    actuator length ``length`` [m], and its derivative in the length [N/m]."""

    def value_at(self, t: float, length: float) -> float: ...

    def d_length(self, t: float, length: float) -> float: ...


#: ``(t, y) -> (T1, T2)``: the forces the actuators apply [N] at state ``y`` (a sequence of floats).
ForceFunction: TypeAlias = Callable[[float, Sequence[float]], tuple[float, float]]
#: ``(t, y) ->`` rates of the drive's own states (empty without lag and compliance).
RateFunction: TypeAlias = Callable[[float, Sequence[float]], tuple[float, ...]]


@dataclass(frozen=True)
class DriveFunctions:
    """The drive evaluated for one set of input laws: ``forces(t, y) -> (T1, T2)`` [N] and
    ``rates(t, y)`` of the drive's own states (a tuple, empty without lag and compliance)."""

    forces: ForceFunction
    rates: RateFunction


@dataclass(frozen=True)
class Drive:
    """Actuator chain: ``lag_tau`` [s] or None; ``compliance`` ``(k_a [N/m], c_d [N s/m])`` or None."""

    lag_tau: float | None = None
    compliance: tuple[float, float] | None = None
    offset: int = 6

    @property
    def i_lag(self) -> int | None:
        return self.offset if self.lag_tau is not None else None

    @property
    def i_el(self) -> int | None:
        if self.compliance is None:
            return None
        return self.offset + (2 if self.lag_tau is not None else 0)

    @property
    def n_states(self) -> int:
        return (2 if self.lag_tau is not None else 0) + (2 if self.compliance is not None else 0)

    @property
    def state_names(self) -> tuple[str, ...]:
        return (("f1_lag", "f2_lag") if self.lag_tau is not None else ()) + \
            (("e1", "e2") if self.compliance is not None else ())

    def bind(self, laws: Sequence[ForceLaw]) -> DriveFunctions:
        """The evaluation path for input ``laws`` (two, one per actuator)."""
        u1, u2 = laws[0].value_at, laws[1].value_at
        i_lag, i_el = self.i_lag, self.i_el
        lag_tau, compliance = self.lag_tau, self.compliance
        forces: ForceFunction
        if i_el is not None:
            assert compliance is not None                   # i_el is set exactly with compliance
            ka = compliance[0]
            forces = lambda t, y: (ka * y[i_el], ka * y[i_el + 1])                     # noqa: E731
        elif i_lag is not None:
            forces = lambda t, y: (y[i_lag], y[i_lag + 1])                             # noqa: E731
        else:
            forces = lambda t, y: (u1(t, y[0]), u2(t, y[1]))                           # noqa: E731
        parts: list[RateFunction] = []
        if i_lag is not None:
            assert lag_tau is not None                      # i_lag is set exactly with a lag
            inv_tau = 1.0 / lag_tau
            parts.append(lambda t, y: ((u1(t, y[0]) - y[i_lag]) * inv_tau, (u2(t, y[1]) - y[i_lag + 1]) * inv_tau))
        if i_el is not None:
            assert compliance is not None
            ka, inv_cd = compliance[0], 1.0 / compliance[1]

            elongation_rates: RateFunction
            if i_lag is not None:
                def elongation_rates(t: float, y: Sequence[float]) -> tuple[float, float]:
                    return (y[3] + (y[i_lag] - ka * y[i_el]) * inv_cd,
                            y[4] + (y[i_lag + 1] - ka * y[i_el + 1]) * inv_cd)
            else:
                def elongation_rates(t: float, y: Sequence[float]) -> tuple[float, float]:
                    return (y[3] + (u1(t, y[0]) - ka * y[i_el]) * inv_cd,
                            y[4] + (u2(t, y[1]) - ka * y[i_el + 1]) * inv_cd)
            parts.append(elongation_rates)
        rates: RateFunction
        if not parts:
            rates = lambda t, y: ()                                                     # noqa: E731
        elif len(parts) == 1:
            rates = parts[0]
        else:
            a, b = parts
            rates = lambda t, y: a(t, y) + b(t, y)                                      # noqa: E731
        return DriveFunctions(forces, rates)

    def initial_states(self, t0: float, q0: Sequence[float] | NDArray[np.float64], laws: Sequence[ForceLaw],
                       sources0: Sequence[float] | None = None) -> list[float]:
        """Extra states at ``t0``: lag forces equal to the commanded forces (or ``sources0``), the
        elongations those of the source forces at rest (``e = f / k_a``)."""
        if sources0 is None:
            sources0 = (laws[0].value_at(t0, q0[0]), laws[1].value_at(t0, q0[1]))
        out: list[float] = []
        if self.i_lag is not None:
            out += list(sources0)
        if self.compliance is not None:
            ka = self.compliance[0]
            out += [sources0[0] / ka, sources0[1] / ka]
        return out

    def jacobian(self, t: float, y: NDArray[np.float64], laws: Sequence[ForceLaw]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(dT/dy (2, n), d(extra rates)/dy (n_states, n))`` for state ``y`` of length ``n``."""
        n = len(y)
        du = np.zeros((2, n))
        for i in (0, 1):
            du[i, i] = laws[i].d_length(t, y[i])
        i_lag, i_el = self.i_lag, self.i_el
        if i_lag is not None:
            dsrc = np.zeros((2, n))
            dsrc[0, i_lag] = dsrc[1, i_lag + 1] = 1.0
        else:
            dsrc = du
        rows: list[NDArray[np.float64]] = []
        if self.lag_tau is not None:
            rows.append((du - dsrc) / self.lag_tau)
        if i_el is not None:
            assert self.compliance is not None
            ka, cd = self.compliance
            el = dsrc / cd
            el[0, 3] += 1.0
            el[1, 4] += 1.0
            el[0, i_el] -= ka / cd
            el[1, i_el + 1] -= ka / cd
            rows.append(el)
            dT = np.zeros((2, n))
            dT[0, i_el] = dT[1, i_el + 1] = ka
        else:
            dT = dsrc
        extra = np.vstack(rows) if rows else np.zeros((0, n))
        return dT, extra
