"""Colours of the view: strings by tension, the kinds' fixed colours.

Tensions map to matplotlib's ``plasma`` colour map, its part from dark blue (0 N) to orange
(the scale; the map's pale yellow end would vanish on the page's white), interpolated
between 17 of its colours (:data:`PLASMA_STOPS`, within 3.5/255 of matplotlib's everywhere: a
test compares them) so that the view's start does not wait for matplotlib's import (about a
third of it);
a string carrying no tension (slack, force <= 0) is grey and drawn thin. The scale is the
largest tension seen so far in the session (:class:`TensionScale`), so one colour means one
tension from frame to frame.
"""

from __future__ import annotations

from typing import Final

import numpy as np
from numpy.typing import NDArray

#: RGB 0..255 of what is not coloured by force.
BAR: Final = (70, 90, 120)
ACTUATOR: Final = (230, 120, 30)
SLACK: Final = (150, 150, 150)
NODE: Final = (40, 40, 40)
CONTACT: Final = (220, 20, 60)
PATH: Final = (20, 150, 90)
BODY: Final = (120, 160, 200)
GRID_CELL: Final = (200, 200, 200)
GRID_SECTION: Final = (110, 110, 110)
#: The part of the map used: 0 N at its start, the scale at this fraction of it.
MAP_TOP: Final = 0.8
#: RGB 0..255 of matplotlib's ``plasma`` at 0, MAP_TOP / 16, ..., MAP_TOP.
PLASMA_STOPS: Final = np.array([
    (13, 8, 135), (42, 5, 147), (65, 4, 157), (86, 1, 164), (106, 0, 168), (126, 3, 168), (143, 13, 164),
    (161, 27, 155), (177, 42, 144), (191, 57, 132), (204, 71, 120), (214, 85, 109), (225, 100, 98),
    (234, 116, 87), (242, 132, 75), (248, 149, 64), (252, 166, 54)], dtype=float)


class TensionScale:
    """The largest tension seen so far [N] (at least ``floor``): the top of the colour map."""

    def __init__(self, floor: float = 1e-6):
        self.value = float(floor)

    def update(self, tensions: NDArray[np.float64]) -> float:
        if len(tensions):
            self.value = max(self.value, float(np.max(tensions)))
        return self.value


def tension_colors(tensions: NDArray[np.float64], scale: float) -> NDArray[np.uint8]:
    """(m, 3) RGB 0..255 of ``tensions`` [N] on a colour map over [0, ``scale``] N; slack
    (tension <= 0) grey."""
    t = np.asarray(tensions, dtype=float)
    x = np.clip(t / scale, 0.0, 1.0) * (len(PLASMA_STOPS) - 1)
    stops = np.arange(len(PLASMA_STOPS))
    rgb = np.stack([np.interp(x, stops, PLASMA_STOPS[:, k]) for k in range(3)], axis=-1).round().astype(np.uint8)
    rgb[t <= 0.0] = SLACK
    return rgb.reshape(len(t), 3)


def hex_color(rgb: tuple[int, int, int] | NDArray[np.uint8]) -> str:
    """``#rrggbb`` of an RGB 0..255 colour."""
    r, g, b = (int(v) for v in rgb)
    return f"#{r:02x}{g:02x}{b:02x}"


def legend_html(scale: float, *, bars: str, actuators: bool, strings: bool, bodies: bool, contacts: bool, path: bool,
                normal_force: tuple[float, float] | None = None) -> str:
    """The legend of the 3D view: one swatch per kind of mark shown, the tension scale [N];
    ``bars``: what the bars are called ("" without bars);
    ``normal_force = (height [m], force [N])``: the floor contacts' normal-force lines, this
    high for this force."""
    low, high = (hex_color(c) for c in tension_colors(np.array([1e-12, scale]), scale))
    rows = []
    if bars:
        rows.append((hex_color(BAR), bars))
    if actuators:
        rows.append((hex_color(ACTUATOR), "actuator (cylinder)"))
    if strings:
        rows.append((f"linear-gradient(90deg, {low}, {high})", f"string: tension 0 to {scale:.3g} N"))
        rows.append((hex_color(SLACK), "slack string (thin)"))
    rows.append((hex_color(NODE), "node"))
    if bodies:
        rows.append((hex_color(BODY), "rigid body"))
    if contacts:
        rows.append((hex_color(CONTACT), "contact"))
    if normal_force is not None and normal_force[1] > 1e-6:
        rows.append((hex_color(CONTACT), f"normal force: red line, {normal_force[0]:.3g} m high for {normal_force[1]:.3g} N"))
    if path:
        rows.append((hex_color(PATH), "end effector's path"))
    cells = "".join(f'<div style="display:flex;align-items:center;gap:6px;font-size:12px">'
                    f'<span style="display:inline-block;width:28px;height:8px;background:{swatch}"></span>'
                    f"{text}</div>" for swatch, text in rows)
    return f'<div class="tensegrity-legend">{cells}</div>'
