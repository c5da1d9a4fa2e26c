"""Located events of a simulation: their kinds, and the entry each leaves in a state's log.

A module of its own, outside ``sim``, so that what only names event kinds (the sweep's result
options, plots, the simulator node's messages) does not import the simulator.

Kinds (``index`` in brackets):

- ``fold``: a free actuator's length fell through 0 under the fold limit [the actuator, 0 or 1];
- ``release``: a held actuator's contact force fell through 0, so it is let go [the actuator];
- ``singular``: lambda1 or lambda2 reached its guard, where the class-2 coordinates break
  down; the run stops [the singular set: 0 for lambda1, 1 for lambda2];
- ``limit``: a quasi-static path reached a limit point (no stable equilibrium continues it);
  the run stops [0];
- ``jump``: a quasi-static configuration moved to another minimum (a law that jumps, or an
  initial state that is no minimum) [0];
- ``slack``: a string's length fell through its rest length, so it carries no force [the
  member's index];
- ``taut``: a slack string's length rose through its rest length [the member's index].

``index`` counts from 0 (it indexes arrays); output for people names what it stands for
(:func:`event_subject`: ``rho1``, ``lambda2``, ``member 3``), counted from 1 as every name is.
"""

from __future__ import annotations

from typing import Final, Literal, get_args

#: The kind of a located event (see the module docstring).
EventKind = Literal["fold", "release", "singular", "limit", "jump", "slack", "taut"]
#: Every event kind, in the order above.
EVENT_KINDS: Final[tuple[EventKind, ...]] = get_args(EventKind)
#: A located event in a state's log: ``(t [s], kind, index)``.
LoggedEvent = tuple[float, EventKind, int]


def as_event_kind(text: str) -> EventKind:
    """``text`` (an event kind read from a file) as an :data:`EventKind`; ValueError if it names none."""
    for kind in EVENT_KINDS:
        if text == kind:
            return kind
    raise ValueError(f"unknown event kind {text!r}; kinds: {', '.join(EVENT_KINDS)}")


def event_subject(kind: EventKind, index: int) -> str:
    """What an event of ``kind`` with ``index`` is about, by name, counted from 1 as every
    name is: ``rho1``/``rho2`` for the fold or release of an actuator, ``lambda1``/``lambda2``
    for a singular set, ``member 3`` for a string's slack or taut; ``""`` for the kinds that
    index nothing (``limit``, ``jump``)."""
    if kind in ("fold", "release"):
        return f"rho{index + 1}"
    if kind == "singular":
        return f"lambda{index + 1}"
    if kind in ("slack", "taut"):
        return f"member {index + 1}"
    return ""
