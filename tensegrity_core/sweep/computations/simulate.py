"""``simulate``: run the point's scene (``tensegrity_core.sim.simulate``) and keep scalars.

Results (column names in brackets; times in s, other quantities in the scene's units):

- ``first_event_time`` {kind, actuator}: time of the first event of that kind (``fold``,
  ``release``, ``jump``, ``limit``, ``singular``, ``slack``, ``taut``; default any)
  [``first_<kind>_time``], NaN if none; ``actuator`` counts from 1 as the names do (1: rho1's
  fold or release, lambda1 for ``singular``, the first member for a string's ``slack`` or
  ``taut``) [``first_<kind>_time_<actuator>``];
- ``event_count`` {kind, actuator}: number of such events [``<kind>_count``];
- ``t_end``: time of the last sample (below the duration when the run stopped early);
- ``final`` {of}: the last sample of ``q``, ``qdot``, ``end_effector``, ``applied_forces``,
  ``member_forces``, ``member_lengths``, ``kinetic_energy`` or ``potential_energy``, one column
  per component named after it (``final_rho1``, ``final_force_AB``, ``final_end_effector_x``);
- ``peak`` {of, stat}: the largest (``stat: max``) or smallest value over the run and the
  components of ``kinetic_energy``, ``potential_energy``, ``member_forces``, ``applied_forces``,
  ``q`` or ``end_effector`` [``max_<of>``];
- ``error_vs_reference`` {reference, of}: the largest ``|x(t) - x_ref(t)|`` over the reference's
  samples within the point's run, ``x`` = ``q`` (default) or ``end_effector``, the point's
  samples interpolated linearly; ``reference: base`` (default) is the unvaried base scene's
  run, or a trajectory file (``.npz`` of ``tensegrity simulate -o``) relative to the sweep file;
- ``steps``, ``evaluations``: the integrator's steps and right-hand-side evaluations.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.events import EVENT_KINDS
from tensegrity_core.sweep.checks import Check, OptionError, choice, integer, number, text
from tensegrity_core.sweep.computations.computation import Computation
from tensegrity_core.sweep.computations.results import Options, Probe, ResultDef, ResultSpec, scalar
from tensegrity_core.sweep.units import coordinate_unit

if TYPE_CHECKING:
    from tensegrity_core.sim import Scene, Trajectory

#: What a result about events may ask for: one kind of event, or any.
KIND_CHOICES = ("any", *EVENT_KINDS)
FINAL_OF = ("q", "qdot", "end_effector", "applied_forces", "member_forces", "member_lengths",
            "kinetic_energy", "potential_energy")
PEAK_OF = ("kinetic_energy", "potential_energy", "member_forces", "applied_forces", "q", "end_effector")
XYZ = ("x", "y", "z")
#: The ``actuator`` option: counted from 1, as rho1, rho2 (and lambda1, lambda2) are.
ACTUATOR = integer(lo=1, what="an actuator (counted from 1: 1 = rho1, 2 = rho2)")


def _events(traj: Trajectory, options: Options) -> list[float]:
    kind, actuator = options.get("kind", "any"), options.get("actuator")
    return [t for t, k, i in traj.events if kind in ("any", k) and actuator in (None, i + 1)]


def _event_column(stem: str, options: Options) -> str:
    kind = options.get("kind", "any")
    name = stem.format(kind="event" if kind == "any" else kind)
    return name if options.get("actuator") is None else f"{name}_{options['actuator']}"


def _first_event(traj: Trajectory, options: Options, data: object) -> list[float]:
    times = _events(traj, options)
    return [min(times) if times else math.nan]


@dataclass(frozen=True)
class _Components:
    """The columns of a ``final`` result: their names and units."""

    names: list[str]
    units: list[str]


def _components(traj: Trajectory, of: str) -> _Components:
    """Column names and units of the components of ``of`` in trajectory ``traj``."""
    if of in ("kinetic_energy", "potential_energy"):
        return _Components([f"final_{of}"], ["J"])
    if of == "end_effector":
        return _Components([f"final_end_effector_{a}" for a in XYZ], ["m"] * 3)
    if of in ("q", "qdot"):
        nq = traj.q.shape[1]
        names = list(traj.state_names)
        names = names[:nq] if of == "q" else names[nq:2 * nq]
        if len(names) != nq:
            names = [f"{of}_{i + 1}" for i in range(nq)]
        return _Components([f"final_{n}" for n in names], [coordinate_unit(n) for n in names])
    if of == "applied_forces":
        names = list(traj.actuator_names) or [str(i + 1) for i in range(traj.applied_forces.shape[1])]
        return _Components([f"final_applied_{n}" for n in names], [_input_unit(traj)] * len(names))
    prefix, unit = ("force", "N") if of == "member_forces" else ("length", "m")
    return _Components([f"final_{prefix}_{n}" for n in traj.member_names], [unit] * len(traj.member_names))


def _input_unit(traj: Trajectory) -> str:
    """Class-2 inputs are forces [N], a general structure's its actuators' rest lengths [m]."""
    model = traj.scene.get("model") if isinstance(traj.scene, dict) else None
    return "N" if isinstance(model, dict) and model.get("kind") == "class2" else "m"


def _quantity_unit(traj: Trajectory, of: str) -> str:
    """The unit of a ``peak``'s quantity; the coordinates' units joined when they differ."""
    if of == "q":
        return ", ".join(dict.fromkeys(coordinate_unit(n) for n in list(traj.state_names)[:traj.q.shape[1]]))
    return {"kinetic_energy": "J", "potential_energy": "J", "member_forces": "N", "end_effector": "m",
            "applied_forces": _input_unit(traj)}[of]


def _final_values(traj: Trajectory, options: Options, data: _Components) -> list[float]:
    n = len(data.names)
    if not len(traj):
        return [math.nan] * n
    values = np.asarray(getattr(traj, options["of"])[-1], dtype=float).ravel()
    if values.size != n:      # a point whose model differs in size from the base's
        return [math.nan] * n
    return [float(v) for v in values]


def _peak(traj: Trajectory, options: Options, data: object) -> list[float]:
    values = np.asarray(getattr(traj, options["of"]), dtype=float)
    if not values.size or not np.isfinite(values).any():
        return [math.nan]
    return [float(np.nanmax(values) if options.get("stat", "max") == "max" else np.nanmin(values))]


def _reference(options: Options, probe: Probe[Trajectory],
               folder: str) -> tuple[NDArray[np.float64], NDArray[np.float64], str]:
    """(times, values, their unit) of the reference run for ``error_vs_reference``."""
    of = options.get("of", "q")
    ref = options.get("reference", "base")
    if ref == "base":
        traj = probe(full=True)
        if not traj.success:
            raise OptionError(f"the base scene's own run (the reference) stopped early: {traj.message}")
    else:
        from tensegrity_core.sim import Trajectory

        path = (Path(folder) / ref)
        if path.suffix.lower() != ".npz":
            raise OptionError(f"must be 'base' or a trajectory file (.npz), got {ref!r}")
        try:
            traj = Trajectory.from_npz(path)
        except (OSError, KeyError, ValueError) as err:
            raise OptionError(f"cannot read the reference trajectory {str(path)!r}: {err}") from None
    return np.asarray(traj.times, dtype=float), np.asarray(getattr(traj, of), dtype=float), _quantity_unit(traj, of)


def _error_vs_reference(traj: Trajectory, options: Options,
                        data: tuple[NDArray[np.float64], NDArray[np.float64], str]) -> list[float]:
    t_ref, x_ref, _ = data
    x = np.asarray(getattr(traj, options.get("of", "q")), dtype=float)
    if len(traj) < 2 or x.shape[1:] != x_ref.shape[1:]:
        return [math.nan]
    t = np.asarray(traj.times, dtype=float)
    inside = (t_ref >= t[0]) & (t_ref <= t[-1])
    if not inside.any():
        return [math.nan]
    x = x.reshape(len(t), -1)
    xr = x_ref.reshape(len(t_ref), -1)[inside]
    err = max(float(np.max(np.abs(np.interp(t_ref[inside], t, x[:, j]) - xr[:, j]))) for j in range(x.shape[1]))
    return [err]


def _stat(key: str) -> Callable[[Trajectory], int | None]:
    def read(traj: Trajectory) -> int | None:
        v = traj.stats.get(key)
        return int(v) if isinstance(v, (int, float)) else None
    return read


RESULTS: dict[str, ResultDef[Trajectory]] = {
    "first_event_time": ResultDef(
        doc="time of the first event of a kind [s]",
        columns=lambda o, d: [(_event_column("first_{kind}_time", o), "float")],
        extract=_first_event, options={"kind": choice(*KIND_CHOICES), "actuator": ACTUATOR}, unit="s"),
    "event_count": ResultDef(
        doc="number of events of a kind",
        columns=lambda o, d: [(_event_column("{kind}_count", o), "int")],
        extract=lambda traj, o, d: [len(_events(traj, o))],
        options={"kind": choice(*KIND_CHOICES), "actuator": ACTUATOR}, unit="count"),
    "t_end": scalar("t_end", "float", lambda traj: float(traj.times[-1]) if len(traj) else math.nan,
                    "time of the last sample [s]", "s"),
    "final": ResultDef(
        doc="the last sample of a quantity, one column per component",
        columns=lambda o, d: [(c, "float") for c in d.names], extract=_final_values,
        options={"of": choice(*FINAL_OF)},
        prepare=lambda o, probe, folder: _components(probe(full=False), o["of"]),
        unit=lambda o, d, column: d.units[d.names.index(column)]),
    "peak": ResultDef(
        doc="largest or smallest value over the run and the components",
        columns=lambda o, d: [(f"{o.get('stat', 'max')}_{o['of']}", "float")], extract=_peak,
        options={"of": choice(*PEAK_OF), "stat": choice("max", "min")},
        prepare=lambda o, probe, folder: _quantity_unit(probe(full=False), o["of"]), unit=lambda o, d, column: d),
    "error_vs_reference": ResultDef(
        doc="largest deviation from a reference run",
        columns=lambda o, d: [("error_vs_reference" if o.get("of", "q") == "q"
                               else f"error_vs_reference_{o['of']}", "float")],
        extract=_error_vs_reference, options={"reference": text, "of": choice("q", "end_effector")},
        prepare=_reference, unit=lambda o, d, column: d[2]),
    "steps": scalar("steps", "int", _stat("steps"), "integrator steps", "count"),
    "evaluations": scalar("evaluations", "int", _stat("nfev"), "right-hand-side evaluations", "count"),
}
REQUIRED_OPTIONS: dict[str, tuple[str, ...]] = {"final": ("of",), "peak": ("of",)}


class Simulate(Computation["Scene", "Trajectory"]):
    name = "simulate"
    base = "scene"
    model = None
    options: dict[str, Check] = {"duration": number(lo=0.0, lo_open=True)}
    results = RESULTS
    required = REQUIRED_OPTIONS
    uses_seed = True
    required_options: tuple[str, ...] = ()
    modules = ("tensegrity_core.sim",)

    def load(self, document: dict[str, Any]) -> Scene:
        from tensegrity_core.sim import load_scene

        return load_scene(document)

    def run(self, scene: Scene, options: Options) -> tuple[bool, str, Trajectory]:
        from tensegrity_core.sim import simulate

        traj = simulate(scene, duration=options.get("duration"))
        return traj.success, traj.message, traj

    def probe(self, document: dict[str, Any], options: Options, *, full: bool) -> Trajectory:
        """The base scene's run: whole (a reference) or its first output interval (names, sizes)."""
        scene = self.load(document)
        duration = options.get("duration", scene.duration)
        if not full:
            duration = min(duration, 1.0 / scene.output_rate)
        return self.run(scene, {"duration": duration})[2]

    def finish_options(self, options: Options, results: Sequence[ResultSpec]) -> Options:
        return options

    def violations(self, outcome: Trajectory) -> list[str]:
        """What the run broke (:mod:`tensegrity_core.sim.invariants`): a leak through the fold
        limit, a stop that pulls, events out of order."""
        return list(outcome.violations)


SIMULATE = Simulate()
