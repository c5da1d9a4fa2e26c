"""Commanded inputs: their values before the first command, and the check of a new command.

An input whose law is "commanded" holds the last value given to the simulator (zero-order
hold); its value before the first command is the scene's ``initial`` or, without one, the
back end's *hold value* (class-2: the force that keeps the initial state at rest; general:
the member's drawn rest length). A state's ``commands`` lists the current values in input
order, ``nan`` for inputs with a law.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.inputs import Commanded, InputLaw


def initial_commands(laws: Iterable[InputLaw], hold: Sequence[float] | NDArray[np.float64]) -> tuple[float, ...]:
    """The commands before the first one: ``law.initial`` or ``hold[i]`` for commanded inputs,
    ``nan`` for the others."""
    return tuple((float(hold[i]) if law.initial is None else float(law.initial)) if isinstance(law, Commanded)
                 else math.nan for i, law in enumerate(laws))


def compile_inputs(inputs: Mapping[str, InputLaw], hold: Sequence[float] | NDArray[np.float64]
                   ) -> tuple[tuple[InputLaw, ...], tuple[str, ...], tuple[float, ...]]:
    """A scene's ``inputs`` as a back end keeps them, in input order: ``(laws, names, the
    commands before the first one)`` (``hold`` as in :func:`initial_commands`)."""
    laws = tuple(inputs.values())
    return laws, tuple(inputs), initial_commands(laws, hold)


def check_command(values: Iterable[float], laws: Sequence[InputLaw], names: Sequence[str], *,
                  positive: bool = False) -> tuple[float, ...]:
    """``values`` (one finite number per input, in input order) as the new commands: floats
    for commanded inputs, ``nan`` for inputs with a law (their values are ignored).
    ``positive``: commanded values must be > 0 (rest lengths). Raises :class:`SimulationError`."""
    try:
        vals = [float(v) for v in values]
    except (TypeError, ValueError):
        raise SimulationError(f"command must be {len(laws)} numbers ({', '.join(names)}), got {values!r}") from None
    if len(vals) != len(laws):
        raise SimulationError(f"command must have {len(laws)} values ({', '.join(names)}), got {len(vals)}")
    for name, law, v in zip(names, laws, vals):
        if not math.isfinite(v):
            raise SimulationError(f"command for {name} must be finite, got {v!r}")
        if positive and isinstance(law, Commanded) and not v > 0:
            raise SimulationError(f"commanded rest length of {name} must be > 0 m, got {v!r} m")
    return tuple(v if isinstance(law, Commanded) else math.nan for law, v in zip(laws, vals))


def changed(old: tuple[float, ...], new: tuple[float, ...]) -> bool:
    """Whether any commanded value differs (``nan`` entries, inputs with a law, never do)."""
    return any(a != b for a, b in zip(old, new) if not (math.isnan(a) and math.isnan(b)))
