"""The page's control updates, checked before viser applies them: a well-formed update whose
value does not fit its control is refused with one log line and no effect; its client stays
connected.

The page changes a control with one ``GuiUpdateMessage``, ``{uuid, updates: {"value": v}}``
(viser's client sends nothing else). viser casts ``v`` to the type of the control's value
and runs the control's callbacks; its own checks stop at that cast. A client of its own can
send any msgpack value there: a text for a slider raised in viser's handler (a traceback in
the log), ``true`` was 1.0, NaN, infinity or 1e30 steps reached the callbacks, and another
property (``max``) failed an assert. :func:`refusal` takes an update only when

- it sets ``value`` and nothing else;
- a checkbox's or a button's value is a bool;
- a number field's or slider's value is an int or a float (not a bool), finite, integral for
  a field of integers, and a number field's within its ``min`` and ``max``. A slider's value
  outside its limits is taken: the controls clamp it and say so in the page
  (:mod:`.controls`), as for a value typed into its field;
- other controls (the view has none) are left to viser.

:func:`install` puts the check in front of viser's handler of these messages (once per
process; every viser server made afterwards has it).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Mapping
from typing import Any, Final

from tensegrity_core.excerpt import excerpt

LOGGER: Final = logging.getLogger("tensegrity_ros.view")

_installed = {"done": False}
_lock = threading.Lock()


def refusal(control: Any, updates: Mapping[Any, Any]) -> str | None:
    """Why the update ``updates`` of ``control`` (a viser GUI handle) is refused, or None to
    let viser apply it (the module docstring)."""
    if set(updates) != {"value"}:
        return f"it sets {excerpt(sorted(map(str, updates)))}, not only the value"
    value, current = updates["value"], control.value
    if isinstance(current, bool):
        return None if isinstance(value, bool) else f"{excerpt(value)} is not true or false"
    if not isinstance(current, (int, float)):
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"{excerpt(value)} is not a number"
    if not math.isfinite(value):
        return f"{excerpt(value)} is not a finite number"
    if isinstance(current, int) and value != int(value):
        return f"{value!r} is not a whole number"
    lo, hi = getattr(control, "min", None), getattr(control, "max", None)
    slider = type(control).__name__ == "GuiSliderHandle"
    if not slider and ((lo is not None and value < lo) or (hi is not None and value > hi)):
        return f"{value!r} is outside [{lo:g}, {hi:g}]" if lo is not None and hi is not None \
            else f"{value!r} is outside its limit {lo if lo is not None else hi:g}"
    return None


def install() -> None:
    """Check every control update before viser's ``GuiApi`` applies it (once)."""
    from viser import _gui_api

    with _lock:
        if _installed["done"]:
            return
        apply = _gui_api.GuiApi._handle_gui_updates

        async def checked(self: Any, client_id: Any, message: Any) -> None:
            control = self._gui_input_handle_from_uuid.get(message.uuid)
            if control is not None:
                reason = refusal(control, message.updates)
                if reason is not None:
                    LOGGER.warning("tensegrity view: refused a value for %s from client %s: %s",
                                   excerpt(getattr(control, "label", message.uuid), 60), client_id, reason)
                    return
            await apply(self, client_id, message)

        _gui_api.GuiApi._handle_gui_updates = checked  # type: ignore[method-assign]  # the one entry of updates
        _installed["done"] = True
