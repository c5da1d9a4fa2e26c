"""The cable controller's check of a ``cable_states`` message (tensegrity_msgs/CableStates)
before it reads one: the simulator sends none that fails it; a rogue publisher might."""

from __future__ import annotations

import math
from typing import Any

from tensegrity_core.excerpt import clip, excerpt


def unusable_cable_states(msg: Any) -> str:
    """Why a ``cable_states`` message cannot be read (no simulator sends such: a rogue
    publisher), or "" when it can: one rest length and one tension per name, each name once,
    finite rest lengths [m]."""
    n = len(msg.name)
    if len(msg.rest_length) != n or len(msg.tension) != n:
        return f"{n} names but {len(msg.rest_length)} rest lengths and {len(msg.tension)} tensions"
    if len(set(msg.name)) != n:
        return "a cable named twice"
    bad = next((name for name, v in zip(msg.name, msg.rest_length) if not math.isfinite(v)), None)
    if bad is not None:
        return clip(f"the rest length of {excerpt(bad)} is not finite")
    return ""
