"""The invariants a simulated run keeps, checked on its samples and events.

:func:`simulate <tensegrity_core.sim.simulator.simulate>` lists what a run breaks in
``Trajectory.violations``; ``tensegrity simulate`` reports each as an error and sweeps give
the point the status ``violated`` instead of plotting its values silently. Checked:

- every sample finite;
- with the fold limit (class-2): actuator lengths ``>= -LENGTH_TOL``; the contact force of
  a held actuator compressive (``>= -CONTACT_TOL`` of the run's force scale ``1 + max|f| +
  max|lambda|`` [N]) and zero off the stop (a length over ``LENGTH_TOL`` from zero: an
  implicit method's linear algebra leaves a held actuator's length at rounding, ~1e-33 m);
- events in time order, no ``(kind, index)`` twice at one instant and never a contradicting
  pair (fold and release of one actuator, slack and taut of one string).

The property tests of ``tests/sim/test_invariants.py`` check these and the energy balance
over every model's accepted parameters; this module is the run-time report.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from tensegrity_core.events import LoggedEvent as Event

#: Actuator lengths below ``-LENGTH_TOL`` [m] are a leak through the fold limit.
LENGTH_TOL = 1e-9
#: A held actuator's contact force below ``-CONTACT_TOL`` of the force scale pulls.
CONTACT_TOL = 1e-9
#: Event kinds that undo each other.
OPPOSITE = {"fold": "release", "release": "fold", "slack": "taut", "taut": "slack"}


def violations(data: Mapping[str, Any], events: Iterable[Event], *, fold_limit: bool) -> list[str]:
    """One line per broken invariant of a run: its observations ``data`` (arrays over the
    samples: ``t``, ``state``, ``q``, ``applied_forces``, ``contact_forces``) and ``events``;
    ``fold_limit`` whether the scene lists it (class-2)."""
    out: list[str] = []
    t = np.asarray(data["t"], dtype=float)
    state = np.asarray(data["state"], dtype=float)
    if state.size and not np.all(np.isfinite(state)):
        k = int(np.argmax(~np.all(np.isfinite(state), axis=1)))
        out.append(f"the state is not finite at t = {t[k]:.9g} s")
    if fold_limit and len(t):
        out += _fold_limit(t, np.asarray(data["q"], dtype=float), np.asarray(data["applied_forces"], dtype=float),
                           np.asarray(data["contact_forces"], dtype=float))
    out += _event_order(list(events))
    return out


def _fold_limit(t: np.ndarray, q: np.ndarray, forces: np.ndarray, contact: np.ndarray) -> list[str]:
    out = []
    lengths = q[:, :2]
    for i in (0, 1):
        k = int(np.argmin(lengths[:, i]))
        if lengths[k, i] < -LENGTH_TOL:
            out.append(f"actuator length rho{i + 1} = {lengths[k, i]:.3g} m below zero at t = {t[k]:.9g} s "
                       f"(the fold limit leaked)")
    scale = 1.0 + float(np.abs(forces).max(initial=0.0)) + float(np.abs(contact).max(initial=0.0))
    for i in (0, 1):
        k = int(np.argmin(contact[:, i]))
        if contact[k, i] < -CONTACT_TOL * scale:
            out.append(f"the stop of rho{i + 1} pulls: contact force {contact[k, i]:.3g} N at t = {t[k]:.9g} s "
                       f"(a held actuator was not released)")
        off = (contact[:, i] > 0) & (np.abs(lengths[:, i]) > LENGTH_TOL)
        if off.any():
            k = int(np.argmax(off))
            out.append(f"contact force {contact[k, i]:.3g} N on rho{i + 1} = {lengths[k, i]:.3g} m, off its stop, "
                       f"at t = {t[k]:.9g} s")
    return out


def _event_order(events: list[Event]) -> list[str]:
    out = []
    for (t0, k0, i0), (t1, k1, i1) in zip(events, events[1:]):
        if t1 < t0:
            out.append(f"events out of time order: {k1} {i1} at t = {t1:.9g} s after {k0} {i0} at {t0:.9g} s")
    at: dict[float, set[tuple[str, int]]] = {}
    for t, kind, index in events:
        seen = at.setdefault(t, set())
        if (kind, index) in seen:
            out.append(f"{kind} {index} twice at t = {t:.9g} s")
        elif (OPPOSITE.get(kind), index) in seen:
            out.append(f"{kind} {index} and {OPPOSITE[kind]} {index} at one instant, t = {t:.9g} s")
        seen.add((kind, index))
    return out
