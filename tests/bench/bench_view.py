"""The view in the browser (``python -m tests.bench --only view [--full]``): frame rate, latency,
start-up.

Measured in Debian's chromium, headless, on software WebGL (SwiftShader: these machines have
no GPU; the page composited in software, as Chrome does without a GPU: ``tests/view/browser.py``),
the page open at 1280 x 720 px (a user's browser window; the 3D canvas is what the control
panel leaves of it, 892 x 720 px, at a device pixel ratio of 1 that the view's page lowers
to 0.75 and 0.5 while it renders fewer frames than the view sends: ``tensegrity_ros/view/resolution.py``;
each row says the ratio it ended at and the canvas's pixels):

- **frame rate**: frames the page renders per second (animation frames in which the page
  drew with WebGL: viser renders on demand, so an animation frame draws only when the
  scene changed) and states it shows per second (changes of its status line), while the
  simulation runs at real time: the class-2 simulator of the suite over ROS (100 Hz states,
  its actuator forces driven by this process along a circle of +-3 N at 0.5 Hz, so that it
  moves), the 6-bar robot's and the spine's bags (``bags/six_bar_roll``,
  ``bags/spine_release``: 100 states per s at any machine speed, a bag row's window ending
  ``BAG_END_MARGIN`` before the bag does), and (full mode) the 6-bar robot (``six_bar_roll``)
  and the spine (``spine_release``) simulated in the view's process (states as fast as the
  core integrates).
  A window starts once the page's resolution has settled after Play (no change for
  ``SETTLED`` s, at most ``SETTLE_MAX`` s after Play: what a user watching sees).
  Baseline, same browser, same run: the animation frames per second of an empty page of the
  view's server (the browser's own rate: the most a page can render). Target: >= 30 fps for
  the 6-bar and the spine. Beside it, the browser's CPU time per rendered frame (all its
  processes, from ``/proc``): what a frame costs, which a loaded machine does not change
  as much as the rate.
- **latency**: from a ``mechanism_state`` message (received by this process's own
  subscriber, wall time) to the page showing that state's time in its status line
  (``performance.timeOrigin + performance.now()``, the same wall clock); median. Target < 50 ms.
- **ready**: from starting ``tensegrity view --scene class2_at_rest`` to its page answering
  HTTP; baseline ``tensegrity scenes`` (the command line's own start-up). Target < 3 s.

Quick mode (CI's smoke run: every row reported, no speed proven): one start-up (that of the
view of the suite over ROS: the same command, started once instead of twice), the browser's
window ``QUICK_WINDOW``, 0.3 s windows after a settling wait cut to ``QUICK_SETTLE``, the
6-bar robot's bag (the spine's plays through the same code; tests/view/test_browser.py draws
its hulls); full mode: 5 start-ups of ``--scene class2_at_rest``, 15 s windows (a bag's: as
long as it lasts), all rows.
"""

from __future__ import annotations

import contextlib
import http.client
import io
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from tests.bench.harness import Context, Row, benchmark
from tests.process_groups import kill_group, wait_group

TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))
BAGS = Path(__file__).resolve().parents[2] / "bags"
READY = re.compile(r"view ready: http://127\.0\.0\.1:(\d+)")
#: The simulator node's log line once it publishes its states.
SIM_PUBLISHING = re.compile(r"publishing at")
#: Wall time [s] kept between a bag row's window and the bag's end (the view stops there): the
#: page's answer to Play (its "playing at" line) comes after the bag started, by this at most.
BAG_END_MARGIN = 0.5
#: The browser's window [px] (a user's).
WINDOW = (1280, 720)
#: Quick mode's window [px]: software WebGL's cost grows with the canvas's pixels, and the page
#: renders the whole time it plays (the control panel keeps its width: a 572 x 540 px canvas).
QUICK_WINDOW = (960, 540)
#: A playing page's resolution has settled when it did not change for this long [s],
SETTLED = 1.0
#: or this long [s] after Play at the most (two steps down take the page about that long).
SETTLE_MAX = 1.5
#: Quick mode's (SETTLED, SETTLE_MAX) [s]: the same wait, cut short (its rows claim no speed).
QUICK_SETTLE = (0.2, 0.3)
#: The page's resolution: the canvas's size [CSS px], its drawn pixels, the device pixel ratio.
RESOLUTION = """() => { const c = document.querySelector('canvas[data-engine^="three.js"]');
  const r = window.__tensegrityResolution || {};
  return [c.clientWidth, c.clientHeight, c.width, c.height, r.dpr ?? window.devicePixelRatio, r.changes ?? 0]; }"""

#: Before any page script: counts the animation frames in which WebGL drew (``__rendered``).
COUNT_RENDERS = """(() => { window.__tick = 0; window.__rendered = 0; let drawn = -1;
  for (const C of [window.WebGLRenderingContext, window.WebGL2RenderingContext]) {
    if (!C) continue;
    for (const f of ["drawArrays", "drawElements", "drawArraysInstanced", "drawElementsInstanced"]) {
      const original = C.prototype[f];
      if (!original) continue;
      C.prototype[f] = function (...a) {
        if (drawn !== window.__tick) { drawn = window.__tick; window.__rendered++; }
        return original.apply(this, a); };
    } }
  const tick = () => { window.__tick++; requestAnimationFrame(tick); };
  requestAnimationFrame(tick); })()"""
#: Page-side probes: [animation frames, rendered frames] per second in a window, and
#: (t shown, wall time [ms]) of each state shown.
FRAMES = """ms => new Promise(r => { let n = 0; const t0 = performance.now(), r0 = window.__rendered;
  function f() { n++; if (performance.now() - t0 < ms) requestAnimationFrame(f);
                 else { const s = (performance.now() - t0) / 1000; r([n / s, (window.__rendered - r0) / s]); } }
  requestAnimationFrame(f); })"""
WATCH = """() => { window.__shown = []; const seen = new Set();
  new MutationObserver(() => { const m = document.body.innerText.match(/t = ([0-9.]+) s/);
    if (m && !seen.has(m[1])) { seen.add(m[1]);
      window.__shown.push([parseFloat(m[1]), performance.timeOrigin + performance.now()]); } })
  .observe(document.body, {subtree: true, childList: true, characterData: true}); }"""


def _launch(name: str, command: list[str], ready: re.Pattern, env: dict,
            log: Path) -> tuple[subprocess.Popen, re.Match]:
    """``command`` (``name`` in errors) started in a session of its own, its output to ``log``,
    once ``ready`` matches in that output (120 s at most: else the process is killed and a
    RuntimeError gives the log's end)."""
    with open(log, "w") as out:
        proc = subprocess.Popen(command, stdout=out, stderr=out, env=env, start_new_session=True)
    deadline = time.monotonic() + 120
    while not (m := ready.search(log.read_text(errors="replace"))):
        if proc.poll() is not None or time.monotonic() > deadline:
            kill_group(proc)
            raise RuntimeError(f"{name} did not start: {log.read_text(errors='replace')[-500:]}")
        time.sleep(0.005)
    return proc, m


def _start(args: list[str], env: dict) -> tuple[subprocess.Popen, int, float]:
    """A view process, its port and the seconds until its page answered (its output goes to a
    file removed once the page answers: the process keeps writing to the unlinked file)."""
    log = Path(tempfile.mkstemp(prefix="bench_view_", suffix=".log")[1])
    try:
        t0 = time.monotonic()
        proc, m = _launch("the view", [TENSEGRITY, "view", *args, "--port", "0"], READY, env, log)
    finally:
        log.unlink()
    port = int(m.group(1))
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    conn.request("GET", "/")
    conn.getresponse().read()
    conn.close()
    return proc, port, time.monotonic() - t0


def _timeline_seconds(page) -> float:
    """The length [s] of the timeline a bag's page plays (its header stamps' span, the end of
    the page's time slider: the view reads the bag once, this process does not read it again)."""
    from tests.view.browser import control

    return float(control(page, "time [s]").get_by_role("slider").get_attribute("aria-valuemax"))


def _browser_cpu_s() -> float:
    """CPU time [s] (user + system) used so far by the chromium processes this process started
    (its descendants named ``chrom*``; Playwright's driver is not among them)."""
    tick = os.sysconf("SC_CLK_TCK")
    parent: dict[int, int] = {}
    used: dict[int, tuple[str, float]] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:                  # a process that ended meanwhile
            continue
        name, fields = stat[stat.index("(") + 1:stat.rindex(")")], stat[stat.rindex(")") + 2:].split()
        parent[int(entry)] = int(fields[1])
        used[int(entry)] = (name, (int(fields[11]) + int(fields[12])) / tick)
    me, total = os.getpid(), 0.0
    for pid, (name, seconds) in used.items():
        ancestor = pid
        while ancestor in parent and ancestor not in (me, 0, 1):
            ancestor = parent[ancestor]
        if ancestor == me and name.startswith("chrom"):
            total += seconds
    return total


def _stop(proc: subprocess.Popen) -> None:
    proc.send_signal(2)
    try:
        wait_group(proc, 30)
    finally:
        kill_group(proc)


def _settle(page, settled: float = SETTLED, at_most: float = SETTLE_MAX) -> float:
    """Wait until the page's resolution has settled (no change for ``settled`` s, at most
    ``at_most`` s: module docstring); the seconds waited."""
    t0 = time.monotonic()
    changes, since = page.evaluate(RESOLUTION)[-1], t0
    while time.monotonic() - since < settled and time.monotonic() - t0 < at_most:
        page.wait_for_timeout(100)
        now_changes = page.evaluate(RESOLUTION)[-1]
        if now_changes != changes:
            changes, since = now_changes, time.monotonic()
    return time.monotonic() - t0


def _resolution_note(page, settled: float | None, changes: int) -> str:
    """The canvas's size, its drawn pixels and pixel ratio now, how long the page settled and
    how often its resolution changed since ``changes`` (the count at the window's start)."""
    css_w, css_h, w, h, dpr, now = page.evaluate(RESOLUTION)
    after = f", window from {settled:.1f} s after Play" if settled is not None else ""
    return (f"canvas {css_w} x {css_h} px drawn at {w} x {h} (pixel ratio {dpr:g}; {now - changes} changes "
            f"in the window{after})")


def _page_rates(browser, url: str, seconds: float, play: str = "", *, empty: bool = False,
                bag: bool = False, settle: tuple[float, float] = (SETTLED, SETTLE_MAX),
                ) -> tuple[float, float, float, list, float, str]:
    """(animation frames per s, frames rendered per s, states shown per s, [(t shown, wall ms)],
    the browser's CPU time per rendered frame [s], the canvas's resolution at the end) over
    ``seconds``; ``play``: press the page's Play first, until the page shows this text, and
    wait for the page's resolution to settle (``settle``: :func:`_settle`'s two lengths [s]);
    ``empty``: a page with nothing to draw;
    ``bag``: a bag's page, the window shortened to end ``BAG_END_MARGIN`` before the bag does."""
    from tests.view.browser import wait_for_canvas

    page = browser.open(url)
    try:
        wait_for_canvas(page, drawn=not empty)
        settled = None
        ends = _timeline_seconds(page) if bag else None
        if play:
            page.get_by_role("button", name="Play").click()
            page.get_by_text(play).first.wait_for()
            settled = _settle(page, *settle)
            if ends is not None:
                asked, seconds = seconds, min(seconds, ends - settled - BAG_END_MARGIN)
                if seconds < min(asked, 0.5):
                    raise RuntimeError(f"the page settled {settled:.1f} s after Play: too late in a {ends:.1f} s bag")
        page.evaluate(WATCH)
        changes = page.evaluate(RESOLUTION)[-1]
        cpu = _browser_cpu_s()
        ticks, rendered = page.evaluate(FRAMES, seconds * 1000)
        cpu = _browser_cpu_s() - cpu
        note = _resolution_note(page, settled, changes) + f"; a {seconds:.1f} s window"
        shown = page.evaluate("() => window.__shown")
        span = (shown[-1][1] - shown[0][1]) / 1000 if len(shown) > 1 else 0.0
        per_frame = cpu / (rendered * seconds) if rendered > 0 else math.inf
        return ticks, rendered, (len(shown) - 1) / span if span > 0 else 0.0, shown, per_frame, note
    finally:
        page.close()


@benchmark
def view_in_the_browser(ctx: Context) -> list[Row]:
    from tests.view.browser import Browser, chromium_available

    if not chromium_available():
        print("   view: skipped, Debian's chromium is not installed (./run test installs it)", file=sys.stderr)
        return []
    import rclpy
    from rclpy.context import Context as RosContext
    from tensegrity_msgs.msg import ActuatorForces, MechanismState

    seconds = 0.3 if ctx.quick else 15.0
    settle = QUICK_SETTLE if ctx.quick else (SETTLED, SETTLE_MAX)
    starts = 1 if ctx.quick else 5
    env = dict(os.environ)
    rows: list[Row] = []

    base = []
    for _ in range(starts):
        t0 = time.monotonic()
        subprocess.run([TENSEGRITY, "scenes"], capture_output=True, env=env, check=True)
        base.append(time.monotonic() - t0)
    # quick mode: the start-up of the view of the suite over ROS below (the same command) stands for these
    ready = []
    for _ in range(0 if ctx.quick else starts):
        proc, _port, took = _start(["--scene", "class2_at_rest"], env)
        ready.append(took)
        _stop(proc)
    rows.append(Row("view", "tensegrity scenes: start to exit, median", statistics.median(base), "s"))

    browser = Browser(*(QUICK_WINDOW if ctx.quick else WINDOW))
    browser.context.add_init_script(COUNT_RENDERS)
    try:
        # the renderer alone: an empty viser page, served from this process (its server thread
        # idles once the page has loaded: the browser's rate is the browser's own; a process of
        # its own would cost a Python start and viser's import, ~2 CPU s, for nothing measured)
        from tensegrity_ros.view.server import start_server

        bare = start_server(port=0)
        try:
            bare_fps, _, _, _, _, _ = _page_rates(browser, f"http://127.0.0.1:{bare.get_port()}", seconds, empty=True)
        finally:
            with contextlib.redirect_stdout(io.StringIO()):     # viser's "Server stopped": not the table's
                bare.stop()
        rows.append(Row("view", "empty viser page: animation frames per s", bare_fps, "fps"))

        # the 6-bar robot's and the spine's bags (states at 100 Hz, whatever the machine's speed),
        # (full mode) both simulated in the view's process (as fast as the core integrates)
        # (quick mode: the 6-bar's bag alone, the others play through the same code)
        runs = [("6-bar robot bag", [str(BAGS / "six_bar_roll"), "--scene", "six_bar_rest"], "playing at")]
        if not ctx.quick:
            runs += [("spine bag", [str(BAGS / "spine_release")], "playing at"),
                     ("6-bar robot (core, in process)", ["--scene", "six_bar_roll"], "· playing"),
                     ("spine (core, in process)", ["--scene", "spine_release"], "· playing")]
        for name, args, playing in runs:
            proc, port, _ = _start(args, env)
            try:
                _, fps, shown, _, per_frame, note = _page_rates(browser, f"http://127.0.0.1:{port}", seconds,
                                                                play=playing, bag=name.endswith("bag"),
                                                                settle=settle)
            finally:
                _stop(proc)
            rows.append(Row("view", f"{name}: frames rendered per s", fps, "fps", target=">= 30",
                            baseline="empty viser page: animation frames per s", note=note))
            rows.append(Row("view", f"{name}: browser CPU per rendered frame", per_frame, "s",
                            note="all chromium processes"))
            rows.append(Row("view", f"{name}: states shown per s", shown, "1/s",
                            note="new states drawn; a bag's come at 100 Hz, the core's as fast as it integrates"))

        # the class-2 simulator of the suite over ROS
        # the view waits a while for a first state, not for a simulator still starting: it
        # starts once the simulator publishes, whose log a failure of the view shows
        sim_log = Path(tempfile.mkstemp(prefix="bench_view_sim_", suffix=".log")[1])
        try:
            sim, _ = _launch("the simulator", [TENSEGRITY, "node", "sim"], SIM_PUBLISHING, env, sim_log)
        except BaseException:
            sim_log.unlink()
            raise
        received: dict[float, float] = {}
        lock = threading.Lock()
        rctx = RosContext()
        rclpy.init(args=[], context=rctx)
        node = rclpy.create_node("bench_view_probe", context=rctx)

        def on_state(msg) -> None:
            t = round(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, 3)
            with lock:
                received.setdefault(t, time.time() * 1000)

        node.create_subscription(MechanismState, "mechanism_state", on_state, 100)
        forces = node.create_publisher(ActuatorForces, "actuator_forces", 10)

        def drive() -> None:
            """Actuator forces along a circle of 3 N at 0.5 Hz: the mechanism keeps moving."""
            phase = 2 * math.pi * 0.5 * time.monotonic()
            forces.publish(ActuatorForces(name=["f1", "f2"], force=[3 * math.cos(phase), 3 * math.sin(phase)]))

        node.create_timer(0.02, drive)
        from rclpy.executors import SingleThreadedExecutor

        executor = SingleThreadedExecutor(context=rctx)
        executor.add_node(node)
        stop_spinning = threading.Event()

        def spin_until_stopped() -> None:
            while not stop_spinning.is_set():
                executor.spin_once(timeout_sec=0.05)

        spin = threading.Thread(target=spin_until_stopped, daemon=True)
        spin.start()
        try:
            try:
                proc, port, took = _start([], env)
            except RuntimeError as failed:
                raise RuntimeError(f"{failed}\nthe simulator's log: {sim_log.read_text(errors='replace')[-1500:]}") from None
            if ctx.quick:
                ready.append(took)
            try:
                _, fps, shown, samples, _, note = _page_rates(browser, f"http://127.0.0.1:{port}", seconds)
            finally:
                _stop(proc)
        finally:
            stop_spinning.set()
            spin.join()
            executor.shutdown()
            node.destroy_node()
            rclpy.try_shutdown(context=rctx)
            try:
                _stop(sim)
            finally:
                sim_log.unlink()
        with lock:
            latencies = [wall - received[t] for t, wall in samples if t in received]
        rows.append(Row("view", "class-2 (suite over ROS, driven): frames rendered per s", fps, "fps",
                        baseline="empty viser page: animation frames per s", note=note))
        rows.append(Row("view", "class-2 (suite over ROS): states shown per s", shown, "1/s", target=">= 30"))
        if latencies:
            rows.append(Row("view", "class-2: state message to page, median", statistics.median(latencies) / 1000, "s",
                            target="< 50 ms", note=f"{len(latencies)} states"))
    finally:
        browser.close()
    rows.insert(1, Row("view", "tensegrity view: start to page served, median", statistics.median(ready), "s",
                       baseline="tensegrity scenes: start to exit, median", target="< 3 s",
                       note="1 start: the view of the suite over ROS" if ctx.quick else f"{starts} starts"))
    return rows
