"""Screenshots of docs/view.md: ``.venv/bin/python docs/view_screenshots.py [NAME ...]``
(writes docs/img/view/NAME.png; all of them without names).

Each shipped view in Debian's headless chromium (tests/view/browser.py: software WebGL, the
network off loopback blocked): the live suite after a move of node D (``live_class2``), a bag
paused in its fold (``bag_fold``), a general structure (the spine) simulated in the view's
process (``scene_spine``), the 6-bar robot rolling (``scene_six_bar``) and the 6-bar's bag at
the end of its roll (``bag_six_bar``). The views run in the repository's folder with bags named
by relative paths, and a screenshot whose page names an absolute path on this machine (a
user's folders) is refused.
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

from tests.view.browser import Browser, status_time, wait_for_canvas  # noqa: E402

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


def _wait_until(page, condition) -> None:
    while not condition():
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
    shown = absolute_paths(page.inner_text("body"))
    if shown:
        raise RuntimeError(f"{name}: the page shows {shown}: name files by paths relative to {ROOT}")
    page.screenshot(path=str(OUT / name))
    page.close()
    print(f"wrote {OUT / name}")


def _move(page) -> None:
    page.get_by_role("button", name="Move D").click()
    page.get_by_text("move: D at").first.wait_for()


def _fold(page) -> None:
    page.get_by_role("button", name="Play").click()
    _wait_until(page, lambda: status_time(page) > 3.2)
    page.get_by_role("button", name="Pause").click()


def _play_until(t: float):
    def play(page) -> None:
        page.get_by_role("button", name="Play").click()
        _wait_until(page, lambda: status_time(page) > t)
    return play


#: name: (the view's arguments, what the page does before the screenshot).
SHOTS = {"live_class2": ([], _move),
         "bag_fold": (["bags/fold"], _fold),
         "scene_spine": (["--scene", "spine_release"], _play_until(1.0)),
         "scene_six_bar": (["--scene", "six_bar_roll"], _play_until(1.2)),
         "bag_six_bar": (["bags/six_bar_roll"], _play_until(10.9))}


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
