"""Debian's chromium, headless, driven by Playwright, with every request off loopback blocked.

Playwright (PyPI ``playwright``) drives the machine's ``/usr/bin/chromium`` (never a
browser of its own). WebGL renders on SwiftShader (``--use-angle=swiftshader
--enable-unsafe-swiftshader``; without them Chromium >= 144 leaves the canvas blank); the
page is composited in software (``--disable-gpu-compositing``), as Chrome does on a machine
without a usable GPU: forced onto SwiftShader as well, compositing cost a page of the
moving 6-bar half its frame rate (docs/design/view.md). The
network is blocked twice: a host-resolver rule maps every name but 127.0.0.1 to nothing,
and a route aborts any request whose host is not a loopback address; every request and
websocket the page opens is listed in :attr:`Browser.requests` (blocked or not), so a test
can assert that the page asked for nothing off this machine.
"""

from __future__ import annotations

import io
import ipaddress
import shutil
import tempfile
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np

CHROMIUM = "/usr/bin/chromium"
#: viser's 3D canvas (the plots are canvases too).
CANVAS = 'canvas[data-engine^="three.js"]'
FLAGS = ["--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-gpu-compositing",
         "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
         "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1"]


def chromium_available() -> bool:
    return Path(CHROMIUM).exists() and shutil.which(CHROMIUM) is not None


def is_local(url: str) -> bool:
    """A URL on this machine (loopback), or one that loads nothing (data:, blob:, about:)."""
    parts = urlsplit(url)
    if parts.scheme in ("data", "blob", "about"):
        return True
    host = parts.hostname or ""
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Browser:
    """One headless chromium with a fresh profile; ``open(url)`` gives a page."""

    def __init__(self, width: int = 800, height: int = 500, timeout_s: float = 180.0):
        from playwright.sync_api import sync_playwright

        self._profile = tempfile.mkdtemp(prefix="tensegrity_view_chromium_")
        self._pw = sync_playwright().start()
        try:
            self.context = self._pw.chromium.launch_persistent_context(
                self._profile, executable_path=CHROMIUM, headless=True, args=FLAGS,
                viewport={"width": width, "height": height}, service_workers="block")
        except BaseException:
            self._pw.stop()
            raise
        self.timeout_ms = timeout_s * 1000
        self.requests: list[str] = []
        self.context.route("**/*", self._route)
        self.context.on("request", lambda r: self.requests.append(r.url))

    def _route(self, route) -> None:
        if is_local(route.request.url):
            route.continue_()
        else:
            route.abort("blockedbyclient")

    def open(self, url: str):
        page = self.context.new_page()
        page.set_default_timeout(self.timeout_ms)    # a busy machine renders software WebGL slowly
        page.on("websocket", lambda ws: self.requests.append(ws.url))
        page.goto(url, wait_until="load")
        return page

    def outside(self) -> list[str]:
        """The requests the page made to anything off this machine (blocked, but asked)."""
        return [u for u in self.requests if not is_local(u)]

    def close(self) -> None:
        try:
            self.context.close()
        finally:
            self._pw.stop()
            shutil.rmtree(self._profile, ignore_errors=True)


def canvas_pixels(page) -> np.ndarray:
    """The 3D canvas of a viser page as an (h, w, 3) uint8 array (a screenshot of it)."""
    from PIL import Image

    box = page.locator(CANVAS).first.bounding_box()
    png = page.screenshot(clip=box, animations="allow")    # a canvas never counts as "stable" to Playwright
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def wait_for_canvas(page, timeout_ms: float = 60_000, *, drawn: bool = True) -> None:
    """Until viser's canvas exists and (``drawn``) has drawn something that is not one flat
    colour; first closes viser's notice over the canvas ("Software WebGL rendering detected")."""
    page.locator(CANVAS).first.wait_for(state="visible", timeout=timeout_ms)
    notice = page.locator("button.mantine-Notification-closeButton")
    if notice.count():
        # a click event straight to the button: Playwright's click first waits for the
        # notice's slide-in to come to rest, frames that a busy page draws slowly
        notice.first.dispatch_event("click")
        notice.first.wait_for(state="detached")
    if not drawn:
        return
    deadline_polls = int(timeout_ms / 250)
    for _ in range(deadline_polls):
        if canvas_pixels(page).std() > 1.0:
            return
        page.wait_for_timeout(250)
    raise AssertionError("the 3D canvas stayed one flat colour (is WebGL on SwiftShader working?)")


def control(page, label: str):
    """The row of the GUI control labelled ``label`` (its slider, fields, checkbox)."""
    return page.locator(f"xpath=//label[normalize-space()='{label}']"
                        "/ancestor::div[.//input or .//*[@role='slider']][1]")


def status_time(page) -> float:
    """The simulation time [s] the page's status line shows ("t = 1.234 s")."""
    text = page.get_by_text("t = ").first.inner_text()
    return float(text.split("=")[1].split("s")[0])
