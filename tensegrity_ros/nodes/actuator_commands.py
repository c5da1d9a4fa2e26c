"""Validation of actuator-force commands (tensegrity_msgs/ActuatorForces).

Kept free of rclpy so it can be tested and reused directly. A command names the
actuators it sets; actuators it does not name keep their last commanded force.

Sign convention: a positive force is tensile (pulls the actuator's nodes together;
generalised force -f on rho_i), as the paper's Eq. 48.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from tensegrity_core.class2.names import ACTUATED_JOINTS, ACTUATORS
from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import excerpt

#: Accepted names of each actuator (case, spaces, '_', '-' and '/' ignored: "Actuator_1"
#: and "rho 1" are accepted too).
ACTUATOR_ALIASES: dict[str, int] = {
    **{n: 0 for n in (ACTUATORS[0], ACTUATED_JOINTS[0], "actuator1", "ab", "1")},
    **{n: 1 for n in (ACTUATORS[1], ACTUATED_JOINTS[1], "actuator2", "bc", "2")},
}


class CommandError(TensegrityError, ValueError):
    """A command that is rejected; the message says why (for a throttled warning)."""


@dataclass(frozen=True)
class ForceUpdate:
    """Which actuators a valid command sets, and to what [N]."""

    indices: tuple[int, ...]
    forces: tuple[float, ...]

    def apply(self, current: Sequence[float]) -> list[float]:
        out = list(current)
        for i, f in zip(self.indices, self.forces):
            out[i] = f
        return out


def parse_command(names: Sequence[str], forces: Sequence[float], *, max_abs_force: float) -> ForceUpdate:
    """Check a command and return the update it makes, or raise :class:`CommandError`.

    - ``names`` empty: ``forces`` must hold exactly one value per actuator, in order f1, f2;
    - otherwise one name per force, each a known actuator, none repeated;
    - every force finite and ``|f| <= max_abs_force``.
    """
    forces = list(forces)
    if not names:
        if len(forces) != len(ACTUATORS):
            raise CommandError(
                f"unnamed command must give {len(ACTUATORS)} forces (f1, f2), got {len(forces)}"
            )
        indices = tuple(range(len(ACTUATORS)))
    else:
        if len(names) != len(forces):
            raise CommandError(f"{len(names)} names but {len(forces)} forces")
        idx = []
        for n in names:
            key = "".join(ch for ch in str(n).lower() if ch not in " _-/")
            if key not in ACTUATOR_ALIASES:
                raise CommandError(
                    f"unknown actuator name {excerpt(n)} (known: f1, f2; aliases rho1/rho2, actuator1/2, AB/BC)"
                )
            if ACTUATOR_ALIASES[key] in idx:
                raise CommandError(f"actuator {ACTUATORS[ACTUATOR_ALIASES[key]]} named twice")
            idx.append(ACTUATOR_ALIASES[key])
        indices = tuple(idx)
    for i, f in zip(indices, forces):
        if not math.isfinite(f):
            raise CommandError(f"force for {ACTUATORS[i]} is not finite ({excerpt(f)})")
        if abs(f) > max_abs_force:
            raise CommandError(
                f"force for {ACTUATORS[i]} = {f:g} N exceeds the limit max_force = {max_abs_force:g} N"
            )
    return ForceUpdate(indices, tuple(float(f) for f in forces))
