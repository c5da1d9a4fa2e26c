"""The page's resolution follows its frame rate: lowered while the page cannot draw the frames
the view sends, full again as soon as it is idle (paused, a bag at its end, nothing moving).

On a machine without a GPU the browser draws WebGL in software (SwiftShader), and a frame's
cost is mostly the canvas's pixels (viser's renderer asks for 4x multisampling and a preserved
drawing buffer, which its Python API does not let a page turn off): at half the device pixel
ratio a frame of the 6-bar costs the browser about 0.55 of its CPU time (docs/design/view.md).
viser's own adaptive ratio goes no lower than 0.75 and decides over 2.5 s windows; what
real-time viewers do instead is drop the resolution while the page falls behind and restore
it when the picture stands still, which is this controller.

It runs in the page (``resolution.js``), in each animation frame: over windows of
``WINDOW_MS`` it counts the frames the page rendered (three.js's render counter) and the
animation frames. A window with fewer rendered frames per second than the view sends
(``--fps``) or than ``SMOOTH_FPS``, whichever is less, *and* a render in nearly every animation frame (``BUSY``: the page drawing all
the time; viser renders on demand but keeps rendering for 250 ms after each change, so a
playing page renders in every animation frame it can) lowers the scale one step of
``SCALES``; a window of fewer than ``IDLE_FPS`` renders per second, not busy, puts it back
to 1 (full resolution: a paused view, the one a user looks at closely, is sharp). It sets viser's own "Device Pixel
Ratio" (the Dev Settings entry, ``fixedDpr``) through the store the page exposes
(``window.__viserTestpoints.devSettings``), so the canvas keeps its size on the screen and
only its pixel count changes. A ratio chosen by the user wins: ``?fixedDpr=`` in the URL
leaves the controller off, and one picked in Dev Settings stops it.

viser has no public API for a page script: the controller goes through viser's
``RunJavascriptMessage`` (the message viser itself sends plotly's script with), which viser
keeps in its scene so every page that connects runs it once. The page's state is
``window.__tensegrityResolution`` (``mode``, ``scale``, ``dpr``, ``changes``, ``fps``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Final

#: The scales of the device pixel ratio the page steps through, full first.
SCALES: Final = (1.0, 0.75, 0.5)
#: Rendered frames per second at or above which the page keeps its resolution though the view
#: sends more (``--fps`` 60 on a 60 Hz display would otherwise lower it at every missed frame).
SMOOTH_FPS: Final = 30.0
#: The window [ms] over which the page's frame rate is measured.
WINDOW_MS: Final = 500.0
#: The share of animation frames with a render above which a slow page is busy drawing.
BUSY: Final = 0.75
#: Renders per second below which a page that is not busy is idle (viser redraws a still
#: scene about twice a second).
IDLE_FPS: Final = 5.0

SCRIPT: Final = Path(__file__).with_name("resolution.js")


def page_script(target_fps: float) -> str:
    """The controller's JavaScript for a view that sends ``target_fps`` frames per second at most."""
    config = {"target": min(float(target_fps), SMOOTH_FPS), "scales": list(SCALES), "windowMs": WINDOW_MS, "busy": BUSY,
              "idleFps": IDLE_FPS}
    return f"({SCRIPT.read_text().strip()})({json.dumps(config)});"


def install(server: Any, target_fps: float) -> None:
    """Send every page of ``server`` (a viser server) the controller."""
    from viser import _messages

    server._websock_server.queue_message(_messages.RunJavascriptMessage(source=page_script(target_fps)))
