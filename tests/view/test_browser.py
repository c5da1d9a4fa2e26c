"""The view in a real browser: Debian's chromium, headless, on software WebGL, network blocked.

Pixels are read from screenshots of viser's three.js canvas (viser's notice over it closed). Every request and websocket of the page is recorded
and none may leave 127.0.0.1. The ROS side is checked with the suite's own client: the
simulator's ``joint_states`` (effort = the applied actuator force) and its
``simulation_interfaces`` services. Waits are for conditions, with deadlines far beyond
their usual time; nothing asserts a duration.
"""

from __future__ import annotations

import re
import signal
import time
import types

import numpy as np
import pytest

from tests.ros.test_loopback import sockets_of
from tests.view.browser import Browser, canvas_pixels, chromium_available, control, status_time, wait_for_canvas
from tests.view.support import start_view

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not chromium_available(), reason="needs Debian's chromium (./run test installs it)")]

BAGS = __import__("pathlib").Path(__file__).resolve().parents[2] / "bags"
WAIT = 120.0   # s: a deadline for conditions that usually hold within a second or two
#: The frame rate of the views whose pages play: viser draws for 250 ms after each frame it
#: gets, so at the view's default 60 frames a second a playing page draws without pause in
#: software (about a core of the machine); at 2 it rests half the time. The states shown are
#: still the newest ones (a bag's playhead and the simulators run at real time, not per frame).
PLAYING_FPS = ("--fps", "2")


@pytest.fixture(scope="module")
def browser():
    b = Browser()
    yield b
    b.close()


def _changed(a: np.ndarray, b: np.ndarray, block: int = 8) -> float:
    """Fraction of the canvas's 8 x 8 px blocks whose ink (pixels darker than the white
    background) differs between a and b: the drawing's shape, not its antialiasing (the same
    state drawn twice differs in a few edge pixels)."""
    def ink(img: np.ndarray) -> np.ndarray:
        h, w = (img.shape[0] // block) * block, (img.shape[1] // block) * block
        dark = (img[:h, :w] < 200).any(axis=2)
        return dark.reshape(h // block, block, w // block, block).any(axis=(1, 3))
    return float((ink(a) != ink(b)).mean())


def _until(condition, what: str, timeout: float = WAIT, poll=lambda: time.sleep(0.1)) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"never saw {what}")
        poll()


def _drawn(page) -> None:
    """Until the page has drawn what it shows: two animation frames from now (the status line
    and the scene arrive in one message batch; the canvas draws them in the next frame)."""
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")


def _settled(page) -> None:
    """Until the status line's time is the same 200 ms apart (a paused source's last frame
    shown), then drawn."""
    shown = [status_time(page)]

    def unchanged() -> bool:
        page.wait_for_timeout(200)
        before, shown[0] = shown[0], status_time(page)
        return shown[0] == before

    _until(unchanged, "the page settle", poll=lambda: None)
    _drawn(page)


#: The page's resolution state and how many times its controller changed it.
RESOLUTION_CHANGES = """() => { const c = document.querySelector('canvas[data-engine^="three.js"]');
  const r = window.__tensegrityResolution || {};
  return [r.mode, r.scale, c.width, c.clientWidth, r.changes]; }"""


def _still_for(page, ms: float) -> tuple[np.ndarray, np.ndarray]:
    """The canvas's pixels ``ms`` apart, at full resolution with no change of it in between.

    The page's resolution controller (``tensegrity_ros/view/resolution.py``) may lower the
    device pixel ratio while the page draws its first scene slowly on a loaded machine and put
    it back once idle: the same scene drawn at another resolution differs in a few edge
    blocks, which is not the scene moving. A window in which the resolution changed is
    measured again."""
    def resolution() -> list:
        return page.evaluate(RESOLUTION_CHANGES)

    def window() -> tuple[np.ndarray, np.ndarray] | None:
        before = resolution()
        first = canvas_pixels(page)
        page.wait_for_timeout(ms)
        second = canvas_pixels(page)
        full = before[0] == "adaptive" and before[1] == 1.0 and before[2] == before[3]
        return (first, second) if full and resolution() == before else None

    pair = [None]
    _until(lambda: (pair.__setitem__(0, window()) or pair[0]) is not None, "the page at one full resolution",
           poll=lambda: page.wait_for_timeout(200))
    return pair[0]


def _next_state(client):
    """The first joint state the simulator publishes from now on."""
    client.take_joints()
    return client.wait_joint(timeout=WAIT)


def _only_loopback(browser: Browser, port: int) -> None:
    """Every request of the browser so far went to loopback, and this view's page was loaded."""
    assert browser.outside() == [], f"the page asked for {browser.outside()}"
    assert {f"http://127.0.0.1:{port}/", f"ws://127.0.0.1:{port}/"} <= set(browser.requests), browser.requests


def test_a_bag_plays_pauses_and_scrubs_on_its_timeline(cli, browser):
    view, url, port = start_view(cli, str(BAGS / "fold"), *PLAYING_FPS)
    page = browser.open(url)
    try:
        wait_for_canvas(page)
        assert status_time(page) == 0.0
        still, later = _still_for(page, 500)
        assert _changed(still, later) == 0.0      # nothing moves: the same pixels
        page.get_by_role("button", name="Play").click()
        _until(lambda: status_time(page) > 2.0, "the bag played past 2 s", poll=lambda: page.wait_for_timeout(200))
        page.get_by_role("button", name="Pause").click()
        page.get_by_text("paused at").first.wait_for(timeout=WAIT * 1000)
        _settled(page)
        folded = canvas_pixels(page)
        assert _changed(still, folded) > 0.02
        # scrub back to the start: the first frame's pixels again (a bag's colour scale is fixed)
        control(page, "time [s]").get_by_role("slider").focus()
        page.keyboard.press("Home")
        _until(lambda: status_time(page) == 0.0, "the timeline back at 0 s", poll=lambda: page.wait_for_timeout(200))
        _drawn(page)
        assert _changed(still, canvas_pixels(page)) < 0.25 * _changed(still, folded)
        _only_loopback(browser, port)
    finally:
        page.close()
    assert view.stop() == 0


RESOLUTION = """() => { const c = document.querySelector('canvas[data-engine^="three.js"]');
  return [window.__tensegrityResolution.mode, window.__tensegrityResolution.scale, c.width, c.clientWidth]; }"""


def test_the_page_lowers_its_resolution_while_it_falls_behind_and_restores_it_when_paused(cli, browser):
    """The 6-bar's bag played on a page whose main thread is slowed twentyfold (Chrome's CPU
    throttling: the page then draws fewer frames than the view sends, on any machine): its
    canvas keeps its size on the screen and draws fewer pixels; paused, full resolution
    again. A ratio in the URL (viser's ``fixedDpr``) is the user's: left alone."""
    view, url, port = start_view(cli, str(BAGS / "six_bar_roll"))
    page = browser.open(url)
    try:
        wait_for_canvas(page)
        mode, scale, width, css = page.evaluate(RESOLUTION)
        assert (mode, scale) == ("adaptive", 1.0) and width == css
        cdp = page.context.new_cdp_session(page)
        cdp.send("Emulation.setCPUThrottlingRate", {"rate": 20})
        page.get_by_role("button", name="Play").click()
        _until(lambda: page.evaluate(RESOLUTION)[1] < 1.0, "the resolution lowered",
               poll=lambda: page.wait_for_timeout(200))
        cdp.send("Emulation.setCPUThrottlingRate", {"rate": 1})
        page.get_by_role("button", name="Pause").click()
        _until(lambda: page.evaluate(RESOLUTION)[1:] == [1.0, css, css], "full resolution again",
               poll=lambda: page.wait_for_timeout(200))
        _only_loopback(browser, port)
    finally:
        page.close()
    page = browser.open(f"{url}/?fixedDpr=0.5")
    try:
        wait_for_canvas(page)
        mode, scale, width, css = page.evaluate(RESOLUTION)
        assert mode == "fixed in the URL" and width == round(0.5 * css)
    finally:
        page.close()
    assert view.stop() == 0


def test_a_rolling_six_bar_robot_moves_between_frames(cli, browser):
    """``--scene six_bar_roll`` simulated in the view's process: paused at first, the same
    pixels; played, the robot drawn elsewhere; the contacts' legend shown (which caps are in
    contact, and their forces, is tested on the frames: tests/view/test_frames.py)."""
    view, url, port = start_view(cli, "--scene", "six_bar_roll", *PLAYING_FPS)
    page = browser.open(url)
    try:
        page.set_viewport_size({"width": 1280, "height": 800})     # the robot rolls on, towards the panel
        wait_for_canvas(page)
        still = canvas_pixels(page)
        page.get_by_role("button", name="Play").click()
        _until(lambda: status_time(page) > 0.5, "the robot rolled for 0.5 s", poll=lambda: page.wait_for_timeout(200))
        first = canvas_pixels(page)
        _until(lambda: status_time(page) > 3.0, "the robot rolled for 3 s (over its first edge)", poll=lambda: page.wait_for_timeout(200))
        second = canvas_pixels(page)
        assert _changed(still, first) > 0.01 and _changed(first, second) > 0.01, (_changed(still, first), _changed(first, second))
        page.get_by_text("normal force: red line").first.wait_for(timeout=WAIT * 1000)
        _only_loopback(browser, port)
    finally:
        page.close()
    assert view.stop() == 0


def _contact_red(img: np.ndarray) -> np.ndarray:
    """Where the contacts' crimson (220, 20, 60) shows, lit or shaded: red with little green
    and blue. No string's colour passes (the tension map keeps green >= 50 where it is this
    red: checked in the test)."""
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return (r > 120) & (g < 50) & (b < 100)


def test_a_robot_bag_moves_over_its_timeline_with_its_contacts_marked(cli, browser):
    """``tensegrity view bags/six_bar_roll --scene six_bar_rest``: at its start the 6-bar stands
    with no cap pressing (no contact in the bag's first state: no crimson pixel); scrubbed to
    its end, it is drawn elsewhere with its caps on the floor crimson, and the legend gives
    the normal forces' scale. The bag's frames are fixed, so the pixels do not depend on the
    machine's speed."""
    from tensegrity_ros.view import colors
    from tensegrity_ros.view.bag_source import BagSource

    ramp = colors.tension_colors(np.linspace(1e-9, 1.0, 2001), 1.0)
    assert not _contact_red(ramp[None]).any() and _contact_red(np.array([[colors.CONTACT]])).all()
    bag = BagSource(BAGS / "six_bar_roll", scene="six_bar_rest")
    assert not bag.frame_at(0).contacts and len(bag.frame_at(len(bag._times) - 1).contacts) >= 2
    view, url, port = start_view(cli, str(BAGS / "six_bar_roll"), "--scene", "six_bar_rest")
    page = browser.open(url)
    try:
        page.set_viewport_size({"width": 1280, "height": 800})     # the robot rolls on, towards the panel
        wait_for_canvas(page)
        still = canvas_pixels(page)
        assert _contact_red(still).sum() == 0
        control(page, "time [s]").get_by_role("slider").focus()
        page.keyboard.press("End")
        _until(lambda: status_time(page) >= round(bag.duration, 3) - 1e-3, "the timeline at its end",
               poll=lambda: page.wait_for_timeout(200))
        _drawn(page)
        end = canvas_pixels(page)
        assert _changed(still, end) > 0.01
        assert _contact_red(end).sum() > 20, _contact_red(end).sum()
        # the legend (like the plots) follows a jump on a paused timeline: its normal-force scale
        page.get_by_text("normal force: red line").first.wait_for(timeout=WAIT * 1000)
        _only_loopback(browser, port)
    finally:
        page.close()
    assert view.stop() == 0


def _differ(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of the canvas's pixels whose colour differs by more than 16 of 255 in a channel
    (a translucent hull over the white background differs from it by 19-47)."""
    return float((np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 16).mean())


def test_rigid_bodies_hulls_move_with_their_bodies(browser):
    """The spine's vertebrae (one instanced hull moved by each body's pose) drawn at a state
    where each vertebra is turned by its own angle and moved: the same pixels as the hulls
    drawn from those nodes' positions (a mesh of the placed nodes, the drawing's former way),
    and not those of the hulls left where they were first drawn (the check sees a hull that
    does not follow its body)."""
    from scipy.spatial.transform import Rotation

    from tensegrity_ros.view import colors
    from tensegrity_ros.view.bag_source import BagSource
    from tensegrity_ros.view.drawing import StructureDrawing
    from tensegrity_ros.view.frame import Frame
    from tensegrity_ros.view.server import start_server

    bag = BagSource(BAGS / "spine_release")
    first = bag.frame_at(0)
    nodes = first.nodes.copy()
    for i, (_, idx) in enumerate(bag.topology.bodies[1:], start=1):     # the lowest vertebra is fixed
        body = list(idx)
        centre = nodes[body].mean(axis=0)
        turn = Rotation.from_euler("xz", [6.0 * i, 9.0 * i], degrees=True)
        nodes[body] = centre + turn.apply(nodes[body] - centre) + [0.012 * i, 0.0, 0.0]
    moved = Frame(t=1.0, nodes=nodes, member_forces=first.member_forces, contacts=(), series={}, run_state="recorded")
    server = start_server(port=0)
    try:
        drawing = StructureDrawing(server.scene, bag.topology, first)
        (group,) = drawing._hulls
        server.initial_camera.look_at = tuple(nodes.mean(axis=0))
        server.initial_camera.position = tuple(nodes.mean(axis=0) + np.array([0.0, -1.0, 0.15]))
        note = server.gui.add_markdown("step 0")
        faces = np.vstack([group.faces + 5 * k for k in range(len(group.nodes))])
        page = browser.open(f"http://127.0.0.1:{server.get_port()}")
        try:
            wait_for_canvas(page)

            def shot(step: int, change) -> np.ndarray:
                with server.atomic():
                    change()
                    note.content = f"step {step}"
                page.get_by_text(f"step {step}").first.wait_for(timeout=WAIT * 1000)
                _drawn(page)
                return canvas_pixels(page)

            by_pose = shot(1, lambda: drawing.show(moved))
            meshes = []

            def hulls_at(positions: np.ndarray):
                """The drawing's hulls hidden, a mesh of the hulls over ``positions`` (n, 3) [m] instead."""
                def change() -> None:
                    for handle in drawing.bodies + meshes:
                        handle.visible = False
                    meshes.append(server.scene.add_mesh_simple(
                        f"/reference/{len(meshes)}", positions[group.nodes].reshape(-1, 3).astype(np.float32),
                        faces.astype(np.uint32), color=colors.BODY, opacity=0.35, side="double", cast_shadow=False,
                        receive_shadow=False))
                return change

            by_nodes = shot(2, hulls_at(nodes))
            left = shot(3, hulls_at(first.nodes))
            assert _differ(left, by_nodes) > 0.01, _differ(left, by_nodes)
            assert _differ(by_pose, by_nodes) < 0.1 * _differ(left, by_nodes), (_differ(by_pose, by_nodes),
                                                                                _differ(left, by_nodes))
        finally:
            page.close()
    finally:
        server.stop()


@pytest.fixture(scope="module")
def live(browser, tmp_path_factory):
    """One suite (simulator and controller), one view of it and its page in the browser,
    shared by the live tests in the order they are written (each leaves the suite as the next
    one expects it); the last test closes the page and the view, and the suite stops here."""
    import rclpy

    from tensegrity_ros.apps.sim_client import SimClient
    from tests.ros_support import Proc, open_context

    logs = tmp_path_factory.mktemp("live_view")
    procs: list[Proc] = []

    def start(*args: str, log_name: str) -> Proc:
        procs.append(Proc(list(args), logs / f"{log_name}{len(procs)}.log"))
        return procs[-1]

    with open_context() as ctx:
        client = None
        try:
            sim = start("node", "sim", log_name="sim")
            # the controller's watchdog at 5 s, not its 0.5 s of wall time: the simulator runs at
            # real time beside a software-rendering browser, and a loaded machine stalled it 0.7 s
            # (a move aborted as "the simulator stopped"); the watchdog has tests of its own
            controller = start("node", "controller", "--ros-args", "-p", "state_timeout:=5.0", log_name="controller")
            client = SimClient(rclpy, "view_test_client", context=ctx, record_events=False)
            client.wait_for_services()
            controller.wait_for("controller ready", timeout=WAIT)
            view, url, port = start_view(start, *PLAYING_FPS)
            page = browser.open(url)
            wait_for_canvas(page)
            yield types.SimpleNamespace(sim=sim, controller=controller, client=client, view=view, url=url, port=port,
                                        page=page, context=ctx)
            assert controller.stop(signal.SIGINT) == 0
            assert sim.stop(signal.SIGINT) == 0
        finally:
            if client is not None:
                client.close()
            for proc in procs:
                proc.kill()


@pytest.mark.ros
def test_the_live_view_follows_the_simulator_and_its_sliders_drive_it(live, browser):
    """A slider moved in the page is the force the simulator applies (joint_states' effort),
    the structure is drawn where it moved, a value beyond the limit is clamped and said so;
    pause, then one step through the page moves the clock by exactly one step."""
    from simulation_interfaces.msg import SimulationState

    page, client = live.page, live.client
    before = canvas_pixels(page)
    rho1_before = _next_state(client).position[0]

    # the sliders take the inputs (the controller steps aside); f1 to its end of the range: +5 N, tension
    control(page, "drive from the sliders").locator("input[type=checkbox]").check()
    control(page, "f1 [N]").get_by_role("slider").focus()
    page.keyboard.press("End")
    _until(lambda: any(r.effort[0] == 5.0 for r in client.take_joints()), "the simulator apply f1 = 5 N")
    _until(lambda: abs(_next_state(client).position[0] - rho1_before) > 0.05, "rho1 move by 5 cm")
    t_moved = _next_state(client).stamp_ns / 1e9
    _until(lambda: status_time(page) >= t_moved, "the page show the moved state",
           poll=lambda: page.wait_for_timeout(200))
    assert _changed(before, canvas_pixels(page)) > 0.01

    # a value typed beyond the limit is clamped, and the page says so
    field = control(page, "f1 [N]").locator("input[type=text]")
    field.fill("7")
    field.press("Enter")
    page.get_by_text("clamped to 5 N").first.wait_for(timeout=WAIT * 1000)
    client.take_joints()
    _until(lambda: (rs := client.take_joints()) and rs[-1].effort[0] == 5.0, "f1 stay at 5 N")

    # pause, then one step through the page: the clock moves by exactly one step
    page.get_by_role("button", name="Pause").click()
    _until(lambda: client.call("get_simulation_state").state.state == SimulationState.STATE_PAUSED,
           "the simulator paused")
    page.get_by_text("pause: OK").first.wait_for(timeout=WAIT * 1000)
    paused_at = _next_state(client).stamp_ns
    page.get_by_role("button", name="Step").click()
    client.wait_joint(paused_at + 10_000_000)     # step_size = 1 / publish_rate = 10 ms

    assert all(addr in ("127.0.0.1", "::1") for _proto, addr, _port in sockets_of(live.view.popen.pid))
    _only_loopback(browser, live.port)


def _end_effector_after(ros_context, stamp_ns: int) -> tuple[float, float]:
    """Node D (x, y) [m] from the simulator's ``end_effector``, the first one stamped after ``stamp_ns``."""
    from geometry_msgs.msg import PointStamped
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    node = Node("view_test_end_effector", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    seen: list[PointStamped] = []
    node.create_subscription(PointStamped, "end_effector", seen.append, 10)
    try:
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
            late = [m for m in seen if m.header.stamp.sec * 10**9 + m.header.stamp.nanosec > stamp_ns]
            if late:
                return late[0].point.x, late[0].point.y
        raise AssertionError("never saw an end_effector message after the move")
    finally:
        executor.shutdown()
        node.destroy_node()


@pytest.mark.ros
def test_the_move_fields_send_the_controllers_goal_and_d_ends_at_the_target(live):
    """x, y, duration typed into the page's "Move node D" fields reach the controller's
    move_end_effector action; the simulator's own end_effector then reads the target (the
    controller settles within 1 mm, docs/control.md)."""
    from simulation_interfaces.msg import SimulationState

    page, client = live.page, live.client
    target = (1.42, 0.75)
    # the sliders no longer driving (a slider's command would take the forces from the
    # controller again), the mechanism back at its initial state and command, playing
    # (and the server has taken the uncheck before anything else is clicked: the page's one
    # throttle keeps only the latest GUI message of 50 ms, and a dropped uncheck leaves the
    # sliders commanding against the controller, D 8 mm off the target in one run)
    drive = control(page, "drive from the sliders").locator("input[type=checkbox]")
    if drive.is_checked():
        drive.uncheck()
        page.get_by_text("the sliders let go of").wait_for(timeout=WAIT * 1000)
    client.reset_all()
    page.get_by_role("button", name="Play").click()
    _until(lambda: client.call("get_simulation_state").state.state == SimulationState.STATE_PLAYING,
           "the simulator playing")
    # one field at a time, each until the server shows it back: viser's page sends GUI
    # updates through one 50 ms throttle that keeps only the latest message, so a second
    # field changed within 50 ms of the first would drop the first one's update
    entries = (("x [m]", target[0], (target[0], 0.72, 2)), ("y [m]", target[1], (*target, 2)),
               ("duration [s]", 2.5, (*target, 2.5)))
    for label, value, (gx, gy, gd) in entries:
        field = control(page, label).locator("input").first
        field.fill(str(value))
        field.press("Enter")
        page.get_by_text(f"goal: D to ({gx:g}, {gy:g}) m in {gd:g} s").wait_for(timeout=WAIT * 1000)
    answer = page.get_by_text(re.compile(r"^move: (D at|the controller refused|failed|no controller|no answer)")).first

    def move() -> bool:
        """Press Move D and wait for the answer; False while the view has not yet found the
        controller's action server (it says so at once) or its goal got no answer (a request
        lost while discovery matches the action's endpoints: it says so after 10 s)."""
        page.get_by_role("button", name="Move D").click()
        # a click replaces a "no answer" line at once ("sent" or "no controller"): not an answer
        page.get_by_text(re.compile(r"^move: no answer")).first.wait_for(state="hidden", timeout=WAIT * 1000)
        answer.wait_for(timeout=WAIT * 1000)
        if answer.inner_text().startswith(("move: no controller", "move: no answer")):
            page.wait_for_timeout(200)
            return False
        return True

    _until(move, "the view find the controller")
    line = answer.inner_text()
    # the controller's own tolerance is 0.1 mm over a real-time loop: on a loaded machine its
    # commands arrive late and it reported D 0.18 mm off (GOAL_TOLERANCE_VIOLATED, -5) after
    # settling; its accuracy is the lockstep tests' business, the page's is to deliver the goal
    # and show the answer, and D within 1 mm shows the goal that arrived was this one
    late = re.match(r"move: failed \(-5\): D still ([0-9.eE+-]+) mm from the target", line)
    if late:
        assert float(late.group(1)) < 1.0, line
    else:
        assert line.startswith("move: D at ("), line
        x, y = (float(v) for v in line.split("(")[1].split(")")[0].split(","))
        assert abs(x - target[0]) < 1e-3 and abs(y - target[1]) < 1e-3, line
    done = _next_state(client).stamp_ns
    dx, dy = _end_effector_after(live.context, done)
    assert abs(dx - target[0]) < 1e-3 and abs(dy - target[1]) < 1e-3


@pytest.mark.ros
def test_closing_the_page_and_the_view_leaves_the_suite_running(live):
    from simulation_interfaces.msg import SimulationState

    state = live.client.call("get_simulation_state").state.state
    live.page.close()
    assert live.view.stop() == 0
    assert live.client.call("get_simulation_state").state.state == state == SimulationState.STATE_PLAYING
    assert live.sim.popen.poll() is None and live.controller.popen.poll() is None
    t = _next_state(live.client).stamp_ns
    live.client.wait_joint(t + 100_000_000)        # and its clock goes on
