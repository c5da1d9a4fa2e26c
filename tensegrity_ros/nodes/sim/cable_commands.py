"""Validation of rest-length commands for actuated cables (tensegrity_msgs/CableCommand).

Kept free of rclpy so it can be tested and reused directly. A command names the actuated
cables it sets (the structure's member names of the scene's inputs); cables it does not
name keep their last rest length. What a cable accepts comes from the model
(:class:`~tensegrity_core.sim.model.Interface`): which inputs take commands (the others follow
the scene's law) and each one's range.
"""

from __future__ import annotations

import functools
import math
import operator
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
        """``current`` (one value per input) with this update's values set."""
        if len(self.indices) == len(current) and self.indices == _in_order(len(current)):
            return list(self.values)            # every input, in input order
        out = list(current)
        for i, v in zip(self.indices, self.values):
            out[i] = v
        return out


@functools.cache
def _in_order(n: int) -> tuple[int, ...]:
    """The indices of ``n`` inputs in input order (one tuple per ``n``)."""
    return tuple(range(n))


def every_input(rest_lengths: Sequence[float], interface: Interface) -> InputUpdate | None:
    """The update of a command that sets every input of ``interface``, in input order, to
    ``rest_lengths`` [m] (a lockstep controller's command), checked at once; None when the
    scene does not take rest lengths there or a value is not inside its range
    (:func:`parse_cable_command` then names what is wrong)."""
    if interface.command != "rest_length" or len(rest_lengths) != len(interface.inputs) or not interface.inputs:
        return None
    every = tuple(map(float, rest_lengths))
    in_order = _in_order(len(every))
    return InputUpdate(in_order, every) if _in_range(interface, in_order, every) else None


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
    if not reel_speeds and not tensions and len(rest_lengths) == len(inputs) and inputs \
            and (not names or tuple(names) == inputs):
        update = every_input(rest_lengths, interface)
        if update is not None:
            return update
    lists = {"rest_length": list(map(float, rest_lengths)), "reel_speed": list(map(float, reel_speeds)),
             "tension": list(map(float, tensions))}
    if not len(names) and not any(lists.values()):
        return InputUpdate((), ())
    if not inputs:
        raise CommandError("this scene has no actuated cables: it takes no cable commands but empty ones")
    modes = interface.modes or ("rest_length",) * len(inputs)
    if not names or tuple(names) == inputs:    # every input, in input order (as joint_states names them)
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
    used = set(modes) if len(indices) == len(inputs) else {modes[i] for i in indices}
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
    if used == {"rest_length"} and _in_range(interface, indices, lists["rest_length"]):
        return InputUpdate(tuple(indices), tuple(lists["rest_length"]))
    out = []
    for k, i in enumerate(indices):                    # the first value at fault, named
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
            raise CommandError(f"{what} of {name} = {v:g} {unit} is outside its range {interface.range_text(i)} "
                               f"{unit}")
        out.append(v)
    return InputUpdate(tuple(indices), tuple(out))



@dataclass(frozen=True)
class _Ranges:
    """An interface's inputs as the checks of a whole command take them: which take a rest
    length now (commanded, in rest-length mode), and each input's open range ``(lo, hi)`` [m]."""

    rest_length: tuple[bool, ...]
    lo: tuple[float, ...]
    hi: tuple[float, ...]


#: The ranges of the interface checked last (a simulator checks every command against one).
_last: tuple[Interface, _Ranges] | None = None


def _in_range(interface: Interface, indices: Sequence[int], values: Sequence[float]) -> bool:
    """Every value a rest length inside its input's open range (so finite), that input
    commanded and in rest-length mode: checked in C loops (``map``), not element by element
    (a command of the 6-bar's 24 cables every lockstep step; for so few values numpy's
    per-call overhead costs more). False sends the command to the checks that name the value
    at fault."""
    global _last
    if _last is None or _last[0] is not interface:
        modes = interface.modes or ("rest_length",) * len(interface.inputs)
        _last = interface, _Ranges(tuple(c and m == "rest_length" for c, m in zip(interface.commanded, modes)),
                                   tuple(float(lo) for lo, _ in interface.limits),
                                   tuple(float(hi) for _, hi in interface.limits))
    r = _last[1]
    taking: Sequence[bool] = r.rest_length
    lo: Sequence[float] = r.lo
    hi: Sequence[float] = r.hi
    if indices is not _in_order(len(r.lo)) and (len(indices) != len(r.lo)
                                                or not all(map(operator.eq, indices, range(len(r.lo))))):
        # not every input in order (the cached tuple of a whole command is known by identity)
        taking, lo, hi = [taking[i] for i in indices], [lo[i] for i in indices], [hi[i] for i in indices]
    return all(taking) and all(map(operator.lt, lo, values)) and all(map(operator.lt, values, hi))
