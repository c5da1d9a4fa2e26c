"""Screenshots of docs/view.md: ``.venv/bin/python docs/view_screenshots.py [NAME ...]``
(writes docs/img/view/NAME.png; all of them without names).

Each shipped view in Debian's headless chromium (tests/view/browser.py: software WebGL, the
network off loopback blocked): the live suite after a move of node D (``live_class2``), a bag
at the end of its fold (``bag_fold``), a general structure (the spine) simulated in the view's
process to 1 s (``scene_spine``), the 6-bar robot rolling, at 1.2 s (``scene_six_bar``) and the
6-bar's bag at the end of its roll (``bag_six_bar``). Each shot is of the time it names,
whatever the machine's speed: a scene is stepped there from its start (paused), a bag played
to its end, where it stops; the page at its full resolution (it draws coarser while it plays on a
slow machine: tensegrity_ros/view/resolution.py). The views run in the repository's folder
with bags named by relative paths, and a screenshot whose page names an absolute path on
this machine (a user's folders) is refused.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.view.browser import Browser, control, status_time, wait_for_canvas  # noqa: E402

OUT = ROOT / "docs" / "img" / "view"
TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))


def _start(args: list[str], log: Path) -> tuple[subprocess.Popen, str]:
    with open(log, "w") as out:
        proc = subprocess.Popen([TENSEGRITY, *args], stdout=out, stderr=out, start_new_session=True, cwd=ROOT)
    deadline = time.monotonic() + 180
    while not (m := re.search(r"view ready: (\S+)", log.read_text())):
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(log.read_text())
        time.sleep(0.1)
    return proc, m.group(1)


def _wait_until(page, condition, timeout_s: float = 300.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError(f"the page never showed what the screenshot waits for ({page.url})")
        page.wait_for_timeout(250)


def absolute_paths(text: str) -> list[str]:
    """The words of ``text`` that name an existing absolute path on this machine (a ROS topic
    such as ``/six_bar/cable_states`` is not one)."""
    return [w for w in re.findall(r"(?<![\w.])/[\w.-]+(?:/[\w.-]+)+", text) if Path(w).exists()]


def _shot(browser: Browser, url: str, name: str, act) -> None:
    page = browser.open(url)
    wait_for_canvas(page)            # (closes the notice that WebGL runs in software)
    act(page)
    page.wait_for_timeout(3000)      # the plots are sent every few frames
    _wait_until(page, lambda: page.evaluate("() => window.__tensegrityResolution.scale") == 1.0)
    shown = absolute_paths(page.inner_text("body"))
    if shown:
        raise RuntimeError(f"{name}: the page shows {shown}: name files by paths relative to {ROOT}")
    page.screenshot(path=str(OUT / name))
    page.close()
    print(f"wrote {OUT / name}")


def _move(page) -> None:
    page.get_by_role("button", name="Move D").click()
    page.get_by_text("move: D at").first.wait_for()


def _shows(page, t: float) -> bool:
    """Whether the page shows the state at ``t`` [s] (a state every 10 ms: within half of one)."""
    return abs(status_time(page) - t) < 0.005


def _played_to_end(bag: str):
    """A bag played to its end (where it stops by itself: its last state), the plots holding
    its last 10 s."""
    from tensegrity_ros.view.bag_source import BagSource

    def play(page) -> None:
        source = BagSource(ROOT / bag)
        page.get_by_role("button", name="Play").click()
        _wait_until(page, lambda: _shows(page, source.t0 + source.duration))
    return play


def _stepped_to(t: float, step: float = 0.01):
    """A scene (paused at its start) stepped to ``t`` [s] in steps of ``step`` (``--step``)."""
    def steps(page) -> None:
        field = control(page, "steps").locator("input").first
        field.fill(str(round(t / step)))
        field.press("Enter")
        page.wait_for_timeout(1000)           # the field's value reaches the server (viser sends GUI updates throttled)
        page.get_by_role("button", name="Step").click()
        page.get_by_text(f"{round(t / step)} steps of").first.wait_for()
        _wait_until(page, lambda: _shows(page, t))
    return steps


#: name: (the view's arguments, what the page does before the screenshot).
SHOTS = {"live_class2": ([], _move),
         "bag_fold": (["bags/fold"], _played_to_end("bags/fold")),
         "scene_spine": (["--scene", "spine_release"], _stepped_to(1.0)),
         "scene_six_bar": (["--scene", "six_bar_roll"], _stepped_to(1.2)),
         "bag_six_bar": (["bags/six_bar_roll"], _played_to_end("bags/six_bar_roll"))}


def main(names: list[str]) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("ROS_DOMAIN_ID", "77")
    browser = Browser(1280, 800)
    procs = []
    with tempfile.TemporaryDirectory() as tmp:
        try:
            if "live_class2" in names:       # the live view needs the suite
                procs.append(subprocess.Popen([TENSEGRITY, "up", "--no-formfind"], stdout=subprocess.DEVNULL,
                                              stderr=subprocess.DEVNULL, start_new_session=True))
            for name in names:
                args, act = SHOTS[name]
                view, url = _start(["view", *args, "--port", "0"], Path(tmp) / f"{name}.log")
                procs.append(view)
                _shot(browser, url, f"{name}.png", act)
        finally:
            browser.close()
            for p in procs:
                p.send_signal(2)
            for p in procs:
                p.wait(timeout=60)


if __name__ == "__main__":
    main(sys.argv[1:] or list(SHOTS))
