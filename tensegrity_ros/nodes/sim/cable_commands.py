"""Validation of rest-length commands for actuated cables (tensegrity_msgs/CableCommand).

Kept free of rclpy so it can be tested and reused directly. A command names the actuated
cables it sets (the structure's member names of the scene's inputs); cables it does not
name keep their last rest length. What a cable accepts comes from the model
(:class:`~tensegrity_core.sim.model.Interface`): which inputs take commands (the others follow
the scene's law) and each one's range.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from tensegrity_core.excerpt import excerpt
from tensegrity_core.sim.model import Interface
from tensegrity_ros.nodes.actuator_commands import CommandError

#: At most this many cable names are listed in a message.
_LISTED = 8


@dataclass(frozen=True)
class InputUpdate:
    """Which inputs a valid command sets (input indices), and to what (rest lengths [m])."""

    indices: tuple[int, ...]
    values: tuple[float, ...]

    def apply(self, current: Sequence[float]) -> list[float]:
        out = list(current)
        for i, v in zip(self.indices, self.values):
            out[i] = v
        return out


def listed(names: Sequence[str]) -> str:
    """Names for a message: the first few, then how many more."""
    shown = ", ".join(names[:_LISTED])
    return shown + (f" and {len(names) - _LISTED} more" if len(names) > _LISTED else "")


#: Per motor mode (``Interface.modes``): the CableCommand field that carries its command, what
#: the value is, and its unit.
MODE_FIELDS = {"rest_length": ("rest_length", "rest length", "m"),
               "reel_speed": ("reel_speed", "reel speed", "m/s"),
               "tension": ("tension", "tension", "N")}


def parse_cable_command(names: Sequence[str], rest_lengths: Sequence[float], reel_speeds: Sequence[float],
                        tensions: Sequence[float], interface: Interface) -> InputUpdate:
    """Check a cable command against the model's ``interface``; the update it makes, or
    :class:`~tensegrity_ros.nodes.actuator_commands.CommandError` saying why not.

    - ``names`` and every value list empty: no change (in lockstep it answers a step, which
      runs under the held commands);
    - ``names`` empty means every input, in input order; otherwise each name an input that
      takes commands, none repeated;
    - a cable takes its value from the list of its motor's mode (``Interface.modes``; a
      general structure's cables and a robot's by default: ``rest_length`` [m]; robots may
      have ``reel_speed`` [m/s] or ``tension`` [N] motors): that list gives one value per
      name, finite and inside the input's range (in the mode's unit); a value list no named
      cable's mode uses must be empty, and in a list that some use, the entries of cables of
      another mode must be NaN (not set).
    """
    if interface.command != "rest_length":
        raise CommandError("this scene's inputs are actuator forces (f1, f2), not rest lengths: send "
                           "tensegrity_msgs/ActuatorForces on actuator_forces")
    inputs = interface.inputs
    lists = {"rest_length": [float(v) for v in rest_lengths], "reel_speed": [float(v) for v in reel_speeds],
             "tension": [float(v) for v in tensions]}
    if not len(names) and not any(lists.values()):
        return InputUpdate((), ())
    if not inputs:
        raise CommandError("this scene has no actuated cables: it takes no cable commands but empty ones")
    modes = interface.modes or ("rest_length",) * len(inputs)
    if not names:
        indices = list(range(len(inputs)))
    else:
        position = {name: i for i, name in enumerate(inputs)}
        indices = []
        for name in names:
            i = position.pop(name, None)
            if i is None:
                if name in inputs:
                    raise CommandError(f"cable {name} named twice")
                raise CommandError(f"unknown cable name {excerpt(name)} (actuated cables: {listed(inputs)})")
            indices.append(i)
    used = {modes[i] for i in indices}
    for mode, values in lists.items():
        field, what, _ = MODE_FIELDS[mode]
        if mode in used and len(values) != len(indices):
            raise CommandError(f"{len(names)} names but {len(values)} {what}s" if names else
                               f"unnamed command must give {len(indices)} {what}s ({listed(inputs)}), "
                               f"got {len(values)}")
        if mode not in used and values:
            if not interface.modes:
                raise CommandError(f"{field} commands are not taken: the actuated cables take rest lengths "
                                   f"only (leave {field} empty)")
            raise CommandError(f"no {'named ' if names else ''}cable's motor takes {what}s (leave {field} empty)")
    out = []
    for k, i in enumerate(indices):
        name, mode = inputs[i], modes[i]
        field, what, unit = MODE_FIELDS[mode]
        if not interface.commanded[i]:
            raise CommandError(f"cable {name} follows the scene's law: it takes no commands")
        for other, values in lists.items():
            if other != mode and values and not math.isnan(values[k]):
                raise CommandError(f"cable {name}'s motor takes a {what} [{unit}] ({field}): its "
                                   f"{MODE_FIELDS[other][1]} must be NaN (not set)")
        v = lists[mode][k]
        if not math.isfinite(v):
            raise CommandError(f"{what} of {name} is not finite ({excerpt(v)})")
        lo, hi = interface.limits[i]
        if not lo < v < hi:
            raise CommandError(f"{what} of {name} = {v:g} {unit} is outside its range ({lo:g}, {hi:g}) {unit}")
        out.append(v)
    return InputUpdate(tuple(indices), tuple(out))
