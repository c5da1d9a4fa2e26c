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
"""

from __future__ import annotations

import numpy as np


class Drive:
    """Transmitted actuator forces and the rates of the actuators' own states."""

    def __init__(self, laws, *, lag_tau: float | None = None, compliance: tuple | None = None, offset: int = 6):
        self.laws = list(laws)
        self.tau = lag_tau
        self.i_lag = offset if lag_tau is not None else None
        self.i_el = offset + (2 if lag_tau is not None else 0) if compliance is not None else None
        self.ka, self.cd = compliance if compliance is not None else (None, None)
        self.n_states = (2 if lag_tau is not None else 0) + (2 if compliance is not None else 0)
        self.state_names = (("f1_lag", "f2_lag") if lag_tau is not None else ()) + \
            (("e1", "e2") if compliance is not None else ())
        self.forces = self._choose_forces()
        self.rates = self._choose_rates()

    # -- build-time choice of the evaluation path (no branches per call) --------------------
    def _choose_forces(self):
        u1, u2 = self.laws[0].value_at, self.laws[1].value_at
        if self.i_el is not None:
            ka, i = self.ka, self.i_el
            return lambda t, y: (ka * y[i], ka * y[i + 1])
        if self.i_lag is not None:
            i = self.i_lag
            return lambda t, y: (y[i], y[i + 1])
        return lambda t, y: (u1(t, y[0]), u2(t, y[1]))

    def sources(self, t, y) -> tuple:
        """Source forces ``f_i`` (after the lag, before the compliance) [N]."""
        if self.i_lag is not None:
            return y[self.i_lag], y[self.i_lag + 1]
        return self.laws[0].value_at(t, y[0]), self.laws[1].value_at(t, y[1])

    def _choose_rates(self):
        u1, u2 = self.laws[0].value_at, self.laws[1].value_at
        parts = []
        if self.i_lag is not None:
            il, inv_tau = self.i_lag, 1.0 / self.tau
            parts.append(lambda t, y: ((u1(t, y[0]) - y[il]) * inv_tau, (u2(t, y[1]) - y[il + 1]) * inv_tau))
        if self.i_el is not None:
            ie, ka, inv_cd = self.i_el, self.ka, 1.0 / self.cd
            src = self.sources
            def elongation_rates(t, y):
                f1, f2 = src(t, y)
                return (y[3] + (f1 - ka * y[ie]) * inv_cd, y[4] + (f2 - ka * y[ie + 1]) * inv_cd)
            parts.append(elongation_rates)
        if not parts:
            return lambda t, y: ()
        if len(parts) == 1:
            return parts[0]
        a, b = parts
        return lambda t, y: a(t, y) + b(t, y)

    # -- initial values and Jacobian ---------------------------------------------------------
    def initial_states(self, t0: float, q0, sources0=None) -> list:
        """Extra states at ``t0``: lag forces equal to the commanded forces (or ``sources0``), the
        elongations those of the source forces at rest (``e = f / k_a``)."""
        if sources0 is None:
            sources0 = (self.laws[0].value_at(t0, q0[0]), self.laws[1].value_at(t0, q0[1]))
        out = []
        if self.i_lag is not None:
            out += list(sources0)
        if self.i_el is not None:
            out += [sources0[0] / self.ka, sources0[1] / self.ka]
        return out

    def jacobian(self, t: float, y) -> tuple:
        """``(dT/dy (2, n), d(extra rates)/dy (n_states, n))`` for state ``y`` of length ``n``."""
        n = len(y)
        du = np.zeros((2, n))
        for i in (0, 1):
            du[i, i] = self.laws[i].d_length(t, y[i])
        if self.i_lag is not None:
            dsrc = np.zeros((2, n))
            dsrc[0, self.i_lag] = dsrc[1, self.i_lag + 1] = 1.0
        else:
            dsrc = du
        rows = []
        if self.i_lag is not None:
            lag = (du - dsrc) / self.tau
            rows.append(lag)
        if self.i_el is not None:
            el = dsrc / self.cd
            el[0, 3] += 1.0
            el[1, 4] += 1.0
            el[0, self.i_el] -= self.ka / self.cd
            el[1, self.i_el + 1] -= self.ka / self.cd
            rows.append(el)
            dT = np.zeros((2, n))
            dT[0, self.i_el] = dT[1, self.i_el + 1] = self.ka
        else:
            dT = dsrc
        extra = np.vstack(rows) if rows else np.zeros((0, n))
        return dT, extra
