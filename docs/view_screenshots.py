"""Screenshots of docs/view.md: ``.venv/bin/python docs/view_screenshots.py`` (writes docs/img/view/*.png).

Each shipped view in Debian's headless chromium (tests/view/browser.py: software WebGL, the
network off loopback blocked): the live suite after a move of node D, a bag paused in its
fold, and a general structure (the spine) simulated in the view's process.
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
        proc = subprocess.Popen([TENSEGRITY, *args], stdout=out, stderr=out, start_new_session=True)
    deadline = time.monotonic() + 180
    while not (m := re.search(r"view ready: (\S+)", log.read_text())):
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(log.read_text())
        time.sleep(0.1)
    return proc, m.group(1)


def _wait_until(page, condition) -> None:
    while not condition():
        page.wait_for_timeout(250)


def _shot(browser: Browser, url: str, name: str, act) -> None:
    page = browser.open(url)
    wait_for_canvas(page)            # (closes the notice that WebGL runs in software)
    act(page)
    page.wait_for_timeout(3000)      # the plots are sent every few frames
    page.screenshot(path=str(OUT / name))
    page.close()
    print(f"wrote {OUT / name}")


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("ROS_DOMAIN_ID", "77")
    browser = Browser(1280, 800)
    procs = []
    with tempfile.TemporaryDirectory() as tmp:
        try:
            up = subprocess.Popen([TENSEGRITY, "up", "--no-formfind"], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL, start_new_session=True)
            procs.append(up)
            view, url = _start(["view", "--port", "0"], Path(tmp) / "live.log")
            procs.append(view)

            def move(page) -> None:
                page.get_by_role("button", name="Move D").click()
                page.get_by_text("move: D at").first.wait_for()

            _shot(browser, url, "live_class2.png", move)

            bag, url = _start(["view", str(ROOT / "bags" / "fold"), "--port", "0"], Path(tmp) / "bag.log")
            procs.append(bag)

            def fold(page) -> None:
                page.get_by_role("button", name="Play").click()
                _wait_until(page, lambda: status_time(page) > 3.2)
                page.get_by_role("button", name="Pause").click()

            _shot(browser, url, "bag_fold.png", fold)

            spine, url = _start(["view", "--scene", "spine_release", "--port", "0"], Path(tmp) / "spine.log")
            procs.append(spine)

            def sway(page) -> None:
                page.get_by_role("button", name="Play").click()
                _wait_until(page, lambda: status_time(page) > 1.0)

            _shot(browser, url, "scene_spine.png", sway)
        finally:
            browser.close()
            for p in procs:
                p.send_signal(2)
            for p in procs:
                p.wait(timeout=60)


if __name__ == "__main__":
    main()
