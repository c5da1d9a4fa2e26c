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


def parse_cable_command(names: Sequence[str], rest_lengths: Sequence[float], reel_speeds: Sequence[float],
                        tensions: Sequence[float], interface: Interface) -> InputUpdate:
    """Check a cable command against the model's ``interface``; the update it makes, or
    :class:`~tensegrity_ros.nodes.actuator_commands.CommandError` saying why not.

    - both ``names`` and ``rest_lengths`` empty: no change (in lockstep it answers a step, which
      runs under the held rest lengths);
    - ``names`` empty: ``rest_lengths`` gives every input, in input order; otherwise one name
      per rest length, each an input that takes commands, none repeated;
    - every rest length finite and inside its input's range;
    - ``reel_speeds`` and ``tensions`` empty (no model takes them).
    """
    if interface.command != "rest_length":
        raise CommandError("this scene's inputs are actuator forces (f1, f2), not rest lengths: send "
                           "tensegrity_msgs/ActuatorForces on actuator_forces")
    inputs = interface.inputs
    if not len(names) and not len(rest_lengths) and not len(reel_speeds) and not len(tensions):
        return InputUpdate((), ())
    if not inputs:
        raise CommandError("this scene has no actuated cables: it takes no cable commands but empty ones")
    if len(reel_speeds) or len(tensions):
        what = "reel_speed" if len(reel_speeds) else "tension"
        raise CommandError(f"{what} commands are not taken: the actuated cables take rest lengths only "
                           f"(leave {what} empty)")
    values = [float(v) for v in rest_lengths]
    if not names:
        if len(values) != len(inputs):
            raise CommandError(f"unnamed command must give {len(inputs)} rest lengths ({listed(inputs)}), "
                               f"got {len(values)}")
        indices = list(range(len(inputs)))
    else:
        if len(names) != len(values):
            raise CommandError(f"{len(names)} names but {len(values)} rest lengths")
        indices = []
        for name in names:
            if name not in inputs:
                raise CommandError(f"unknown cable name {excerpt(name)} (actuated cables: {listed(inputs)})")
            i = inputs.index(name)
            if i in indices:
                raise CommandError(f"cable {name} named twice")
            indices.append(i)
    for i, v in zip(indices, values):
        name = inputs[i]
        if not interface.commanded[i]:
            raise CommandError(f"cable {name} follows the scene's law: it takes no commands")
        if not math.isfinite(v):
            raise CommandError(f"rest length of {name} is not finite ({excerpt(v)})")
        lo, hi = interface.limits[i]
        if not lo < v < hi:
            raise CommandError(f"rest length of {name} = {v:g} m is outside its range ({lo:g}, {hi:g}) m")
    return InputUpdate(tuple(indices), tuple(values))
