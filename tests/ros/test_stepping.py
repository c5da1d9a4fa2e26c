"""Stepping tensegrity_sim over ROS 2 (issue 14), with real nodes over DDS on loopback: the
simulation_interfaces contract, lockstep runs equal to the core's sampled-data run and to
each other, /clock exact after pause/step/resume, and every bad-input and fault case."""

from __future__ import annotations

import time

import numpy as np
import pytest

pytestmark = pytest.mark.ros

STEP_NS = 10_000_000          # the tests' step: 10 ms


@pytest.fixture
def stepping(cli, ros_context):
    """Start `tensegrity node sim` with ROS parameters; yields (proc, client)."""
    import rclpy

    from tensegrity_ros.apps.sim_client import SimClient

    clients = []

    def start(*params: str):
        args = ["node", "sim", "--ros-args", "-p", f"step_size:={STEP_NS / 1e9}", "-p", "publish_rate:=100.0"]
        for p in params:
            args += ["-p", p]
        proc = cli(*args, log_name="sim")
        proc.wait_for("publishing at")
        client = SimClient(rclpy, "stepping_test", context=ros_context)
        clients.append(client)
        client.wait_for_services(30)
        return proc, client

    yield start
    for c in clients:
        c.close()


def _clock_listener(ctx):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock

    node = rclpy.create_node("clock_listener", context=ctx)
    got: list[int] = []
    node.create_subscription(Clock, "/clock", lambda m: got.append(m.clock.sec * 10**9 + m.clock.nanosec),
                             QoSProfile(depth=10000))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)

    def spin(seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.01)

    return got, spin


def _spin_until(spin, condition, what: str, timeout: float = 60.0) -> None:
    """Spin the listener until ``condition()`` holds; fail saying ``what`` after ``timeout`` [s]."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"no {what} within {timeout:g} s"
        spin(0.05)


def _standing_clock(clock: list[int], spin, *, above: int = -1) -> int:
    """The simulation time [ns] a paused simulator stands at, once it is above ``above``.

    Playing or stepping, each /clock message is a step later than the one before; paused, the
    simulator republishes its state at ``paused_publish_rate`` with the same stamp. So the
    first time the last two messages received carry the same stamp, every message published
    before the pause or the steps has arrived, and that stamp is where the simulator stands
    (waiting on this condition, not for a fixed time, holds on a loaded machine)."""
    _spin_until(spin, lambda: len(clock) >= 2 and clock[-1] == clock[-2] > above,
                "/clock republished at a standing time" + (f" above {above} ns" if above >= 0 else ""))
    return clock[-1]


def _result(res):
    return res.result.result, res.result.error_message


def _lockstep_fold(client, steps: int) -> list:
    """Reset (clock at 0), then `steps` lockstep steps under the paper's fold law."""
    from tensegrity_core.class2.fold_law import paper_fold_forces

    client.set_law(None)
    client.reset_all()
    client.take_joints()
    client.events.clear()
    client.set_law(paper_fold_forces, until_ns=steps * STEP_NS)
    client.step(steps)
    client.set_law(None)
    client.wait_joint(steps * STEP_NS)
    table = {}
    for j in client.take_joints():
        assert table.setdefault(j.stamp_ns, j) == j          # a republished stamp carries the same state
    return [table[k * STEP_NS] for k in range(steps + 1)]


def test_lockstep_runs_equal_the_core_sampled_run_and_each_other(stepping):
    """The paper's fold over ROS in lockstep (controller in this process) against the core's
    run_sampled with the same controller: every joint state equal to the last bit, the
    located events equal, and a second ROS run identical to the first."""
    from tensegrity_core.class2.fold_law import paper_fold_forces
    from tensegrity_core.sim.sampled import run_sampled

    proc, client = stepping("lockstep:=true", "initial_state:=paused", "paused_publish_rate:=0.0",
                            "lockstep_timeout:=30.0")
    steps = 200                                   # 2 s: through both first folds (1.37 s and 1.54 s)
    first = _lockstep_fold(client, steps)
    events = [(e.time, e.kind, e.index) for e in client.events]
    second = _lockstep_fold(client, steps)
    assert first == second
    core = run_sampled("class2_at_rest", paper_fold_forces, step_ns=STEP_NS, steps=steps)
    assert core.success
    np.testing.assert_array_equal(np.array([j.position for j in first]), core.q)
    np.testing.assert_array_equal(np.array([j.velocity for j in first]), core.qdot)
    assert [j.stamp_ns for j in first] == [k * STEP_NS for k in range(steps + 1)]
    assert [(k, i) for _, k, i in events] == [(k, i) for _, k, i in core.events]
    assert [t for t, _, _ in events] == [t for t, _, _ in core.events]
    assert any(k == "fold" for _, k, _ in events)
    assert "rejected" not in proc.stderr()


def test_a_noisy_scene_in_lockstep_equals_the_core_sampled_run(stepping, tmp_path):
    """Sensor noise feeds back through the controller; the node observes more often than the
    core's run does, and still both see the same noise (it is keyed on the observation time)."""
    from tensegrity_core.class2.fold_law import paper_fold_forces
    from tensegrity_core.sim import scene_path
    from tensegrity_core.sim.sampled import run_sampled

    text = scene_path("class2_at_rest").read_text().replace(
        "  - fold_limit\n", "  - fold_limit\n  - sensor_noise: {q: 1.0e-3, qdot: 1.0e-2}\n") + "seed: 7\n"
    assert "sensor_noise" in text
    scene = tmp_path / "noisy.yaml"
    scene.write_text(text)
    proc, client = stepping(f"scene:={scene}", "lockstep:=true", "initial_state:=paused", "paused_publish_rate:=0.0",
                            "lockstep_timeout:=30.0")
    steps = 100
    ros = _lockstep_fold(client, steps)
    core = run_sampled(str(scene), paper_fold_forces, step_ns=STEP_NS, steps=steps)
    np.testing.assert_array_equal(np.array([j.position for j in ros]), core.q)
    np.testing.assert_array_equal(np.array([j.velocity for j in ros]), core.qdot)
    clean = run_sampled("class2_at_rest", paper_fold_forces, step_ns=STEP_NS, steps=steps)
    assert 1e-4 < np.abs(core.q - clean.q).max() < 0.05          # the noise is there, and fed back
    assert "rejected" not in proc.stderr()


def test_clock_is_exact_after_pause_step_resume_and_never_catches_up(stepping, ros_context):
    from simulation_interfaces.msg import SimulationState

    clock, spin = _clock_listener(ros_context)
    proc, client = stepping()                       # free-running, real time
    _spin_until(spin, lambda: len(clock) >= 10, "ten /clock messages while playing")
    assert _result(client.set_state(SimulationState.STATE_PAUSED))[0] == 1
    paused_at = _standing_clock(clock, spin)        # paused: time stands (republished at 1 Hz)
    client.step(3)
    client.step(1)
    assert _standing_clock(clock, spin, above=paused_at) == paused_at + 4 * STEP_NS   # exactly n steps
    played_from = time.monotonic()
    assert _result(client.set_state(SimulationState.STATE_PLAYING))[0] == 1
    _spin_until(spin, lambda: clock[-1] >= paused_at + 10 * STEP_NS, "ticks after resuming")
    assert _result(client.set_state(SimulationState.STATE_PAUSED))[0] == 1
    played_for = time.monotonic() - played_from
    _standing_clock(clock, spin, above=paused_at + 4 * STEP_NS)
    assert all(c % STEP_NS == 0 for c in clock)     # every stamp on the step grid
    assert clock == sorted(clock)
    resumed = [c for c in clock if c > paused_at + 4 * STEP_NS]
    # no catch-up after the pause: the first tick after resuming is one step on, and the
    # clock then never runs ahead of the wall clock. Tick i is due (i - 1) periods after the
    # first, which came after the play request, and the last came before the pause's answer,
    # so at real time the clock advanced at most the wall time between the two (plus the
    # step grid's rounding); a late machine only makes it advance less.
    assert resumed[0] == paused_at + 5 * STEP_NS
    assert resumed[-1] - resumed[0] <= played_for * 1e9 + STEP_NS


def test_stepping_requests_outside_pause_and_of_bad_size_are_answered(stepping):
    from simulation_interfaces.msg import Result
    from simulation_interfaces.srv import StepSimulation

    proc, client = stepping("max_steps_per_request:=1000")
    res = client.call("step_simulation", StepSimulation.Request(steps=1))
    code, message = _result(res)
    assert code == Result.RESULT_OPERATION_FAILED and "paused" in message   # StepSimulation.srv's code
    from simulation_interfaces.msg import SimulationState

    client.set_state(SimulationState.STATE_PAUSED)
    code, message = _result(client.call("step_simulation", StepSimulation.Request(steps=0)))
    assert code == Result.RESULT_OPERATION_FAILED and "at least 1" in message
    code, message = _result(client.call("step_simulation", StepSimulation.Request(steps=2**63)))
    assert code == Result.RESULT_OPERATION_FAILED and "max_steps_per_request = 1000" in message
    code, _ = _result(client.call("step_simulation", StepSimulation.Request(steps=1000)))
    assert code == Result.RESULT_OK


def test_state_changes_answer_with_the_standard_codes(stepping):
    from simulation_interfaces.msg import Result, SimulationState, SimulatorFeatures
    from simulation_interfaces.srv import ResetSimulation, SetSimulationState

    proc, client = stepping("initial_state:=stopped")
    assert client.call("get_simulation_state").state.state == SimulationState.STATE_STOPPED
    assert _result(client.set_state(SimulationState.STATE_STOPPED))[0] == SetSimulationState.Response.ALREADY_IN_TARGET_STATE
    code, message = _result(client.set_state(42))
    assert code == SetSimulationState.Response.INCORRECT_TRANSITION and "42" in message
    assert _result(client.set_state(SimulationState.STATE_QUITTING))[0] == Result.RESULT_FEATURE_UNSUPPORTED
    assert _result(client.set_state(SimulationState.STATE_NO_WORLD))[0] == SetSimulationState.Response.INCORRECT_TRANSITION
    assert _result(client.set_state(SimulationState.STATE_PAUSED))[0] == Result.RESULT_OK
    assert client.call("get_simulation_state").state.state == SimulationState.STATE_PAUSED
    client.step(5)
    client.wait_joint(5 * STEP_NS)
    code, message = _result(client.call("reset_simulation", ResetSimulation.Request(scope=ResetSimulation.Request.SCOPE_TIME)))
    assert code == Result.RESULT_FEATURE_UNSUPPORTED and "SCOPE_TIME alone" in message
    assert _result(client.call("reset_simulation", ResetSimulation.Request(scope=ResetSimulation.Request.SCOPE_SPAWNED)))[0] \
        == Result.RESULT_FEATURE_UNSUPPORTED
    client.take_joints()
    assert _result(client.call("reset_simulation", ResetSimulation.Request(scope=ResetSimulation.Request.SCOPE_STATE)))[0] \
        == Result.RESULT_OK
    assert client.wait_joint().stamp_ns == 5 * STEP_NS          # state reset, the clock goes on
    client.step(1)
    client.wait_joint(6 * STEP_NS)
    client.take_joints()
    client.reset_all()
    assert client.wait_joint().stamp_ns == 0                    # SCOPE_ALL: the clock back at 0 too
    features = set(client.call("get_simulator_features").features.features)
    f = SimulatorFeatures
    assert features == {f.SIMULATION_RESET, f.SIMULATION_RESET_STATE, f.SIMULATION_STATE_GETTING,
                        f.SIMULATION_STATE_SETTING, f.SIMULATION_STATE_PAUSE, f.STEP_SIMULATION_SINGLE,
                        f.STEP_SIMULATION_MULTIPLE, f.STEP_SIMULATION_ACTION}
    assert f.SPAWNING not in features and f.SIMULATION_RESET_TIME not in features


def test_lockstep_without_a_controller_keeps_publishing_under_the_safe_force(stepping):
    """The controller is dead (nobody answers): every step waits lockstep_timeout, warns
    (throttled) and runs under safe_force; joint states keep coming, one per step."""
    import re

    proc, client = stepping("lockstep:=true", "lockstep_timeout:=0.1", "safe_force:=0.25")
    deadline = time.monotonic() + 60                # until the log counts 10 timed-out steps
    while int((re.findall(r"\((\d+) timed-out steps so far\)", proc.stderr()) or ["0"])[-1]) < 10:
        assert time.monotonic() < deadline, proc.stderr()
        time.sleep(0.1)
    joints = client.take_joints()           # the states of those steps, which may still be on their way
    while len(joints) < 5:
        assert time.monotonic() < deadline, joints
        time.sleep(0.05)
        joints += client.take_joints()
    stamps = [j.stamp_ns for j in joints]
    assert stamps == sorted(stamps) and all(b - a == STEP_NS for a, b in zip(stamps, stamps[1:]))
    assert all(tuple(j.effort[:2]) == (0.25, 0.25) for j in joints[1:])
    log = proc.stderr()
    assert "lockstep: no command for step" in log and "safe_force = 0.25 N" in log
    timed_out = int(re.findall(r"\((\d+) timed-out steps so far\)", log)[-1])
    assert timed_out >= 10 and log.count("lockstep: no command for step") <= timed_out / 5   # throttled


def test_a_lockstep_command_for_another_step_is_rejected_with_a_reason(stepping):
    from tensegrity_msgs.msg import ActuatorForces

    # lockstep_timeout 30 s, a hang guard: with the default 1 s a step whose answer from this
    # process comes later (a loaded machine) runs under safe_force, and the efforts below differ
    proc, client = stepping("lockstep:=true", "initial_state:=paused", "paused_publish_rate:=0.0",
                            "lockstep_timeout:=30.0")
    wrong = ActuatorForces(name=["f1", "f2"], force=[1.0, 1.0])
    wrong.header.stamp.nanosec = 3 * STEP_NS                   # the simulator waits at step 0
    client.pub.publish(wrong)
    deadline = time.monotonic() + 30
    while "rejected actuator command" not in proc.stderr():
        assert time.monotonic() < deadline, proc.stderr()
        time.sleep(0.05)
    log = proc.stderr()
    assert "stamped 0.030000000 s, but the simulator waits at step 0 (t = 0.000000000 s)" in log
    client.set_law(lambda s: (0.5, 0.5))
    client.step(2)                                             # the rejected command was never applied
    client.set_law(None)
    efforts = {j.stamp_ns: tuple(j.effort[:2]) for j in client.take_joints()}
    assert efforts.get(2 * STEP_NS) == (0.5, 0.5) or efforts.get(STEP_NS) == (0.5, 0.5)


@pytest.mark.parametrize("lockstep", [False, True])
def test_cancelling_simulate_steps_stops_at_a_step_boundary(stepping, ros_context, lockstep):
    from rclpy.action import ActionClient
    from simulation_interfaces.action import SimulateSteps
    from simulation_interfaces.msg import SimulationState

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard

    clock, spin = _clock_listener(ros_context)
    proc, client = stepping("initial_state:=paused", "paused_publish_rate:=0.0", f"lockstep:={str(lockstep).lower()}",
                            "lockstep_timeout:=30.0")
    client.set_law(lambda sample: (-0.35, 0.35))       # a controller (used in lockstep only)
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    node = rclpy.create_node("action_test", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    action = ActionClient(node, SimulateSteps, "simulate_steps")
    assert wait_for_action_server(node, action, 30)
    assert wait_until_server_heard(node, "simulate_steps", lambda f, t: spin_until_done(ex, f, t), 30)
    feedback = []

    def send_goal():
        return action.send_goal_async(SimulateSteps.Goal(steps=1_000_000),
                                      feedback_callback=lambda m: feedback.append(m.feedback))

    goal_future = send_goal()
    if not spin_until_done(ex, goal_future, 15):
        # Seen twice in 7 loaded fresh-clone runs, always this first case after the lockstep
        # rejection test, cause not found: no answer although the server was proven to have
        # heard this client. A simulator that took the goal runs it and its steps come on
        # /clock; none came, so the request never reached it, and it is sent once more.
        spin(0.5)
        assert not clock, f"the simulator runs the goal but its answer never came; its log:\n{proc.stderr()}"
        goal_future = send_goal()
        assert spin_until_done(ex, goal_future, 30), proc.stderr()
    handle = goal_future.result()
    assert handle.accepted
    deadline = time.monotonic() + 60
    while len(feedback) < 20:
        assert time.monotonic() < deadline, (feedback, handle.status, proc.stderr())
        ex.spin_once(timeout_sec=0.01)
    cancel = handle.cancel_goal_async()
    assert spin_until_done(ex, cancel, 30)
    result_future = handle.get_result_async()
    assert spin_until_done(ex, result_future, 60)
    res = result_future.result()
    spin(0.5)                                                  # the last feedback may still be in flight
    ex.spin_once(timeout_sec=0.1)
    from action_msgs.msg import GoalStatus

    assert res.status == GoalStatus.STATUS_CANCELED
    message = res.result.result.error_message
    assert message.startswith("cancelled after ")
    done = int(message.split()[2])
    # feedback after every step (a keep-last history of 10 may drop some under load, and
    # rclpy drops feedback that arrives after the result): counts rise, each adds up to the
    # request, none is past the step where the cancel stopped
    assert all(f.completed_steps + f.remaining_steps == 1_000_000 for f in feedback)
    assert all(b.completed_steps > a.completed_steps for a, b in zip(feedback, feedback[1:]))
    assert 20 <= feedback[-1].completed_steps <= done
    # the listener works through its backlog of /clock (thousands of steps a second), then
    # nothing past the boundary arrives: stopped on a step boundary
    deadline = time.monotonic() + 60
    while not (clock and clock[-1] >= done * STEP_NS):
        assert time.monotonic() < deadline, (clock[-1:], done)
        spin(0.1)
    spin(0.5)
    assert clock[-1] == done * STEP_NS
    assert client.call("get_simulation_state").state.state == SimulationState.STATE_PAUSED
    assert "lockstep: no command" not in proc.stderr()      # lockstep: every step had its command
    node.destroy_node()


def test_paced_lockstep_play_never_runs_ahead_of_its_real_time_factor_and_stays_exact(stepping):
    """Lockstep while playing, paced at twice real time: the state at t_k is published no
    sooner than k step / 2 after playing began (a controller sees it no sooner), and the run is
    still the core's sampled-data run to the last bit (pacing only delays publications)."""
    from simulation_interfaces.msg import SimulationState

    from tensegrity_core.class2.fold_law import paper_fold_forces
    from tensegrity_core.sim.sampled import run_sampled

    factor, steps = 2.0, 150
    proc, client = stepping("lockstep:=true", f"lockstep_real_time_factor:={factor}", "initial_state:=paused",
                            "paused_publish_rate:=0.0", "lockstep_timeout:=30.0")
    seen: list[tuple[float, float]] = []

    def law(sample):
        seen.append((time.monotonic(), sample.t))
        return paper_fold_forces(sample)

    client.set_law(None)
    client.reset_all()
    client.take_joints()
    client.set_law(law, until_ns=steps * STEP_NS)
    start = time.monotonic()
    assert _result(client.set_state(SimulationState.STATE_PLAYING))[0] == 1
    client.wait_joint(steps * STEP_NS, timeout=120)
    assert _result(client.set_state(SimulationState.STATE_PAUSED))[0] == 1
    assert [t for _, t in seen] == [k * STEP_NS / 1e9 for k in range(steps)]
    late = [(t, wall - start) for wall, t in seen if t > (wall - start) * factor + 1e-9]
    assert not late, late[:5]                                  # (t [s], wall s after play) seen too early
    table = {}
    for j in client.take_joints():
        assert table.setdefault(j.stamp_ns, j) == j
    core = run_sampled("class2_at_rest", paper_fold_forces, step_ns=STEP_NS, steps=steps)
    np.testing.assert_array_equal(np.array([table[k * STEP_NS].position for k in range(steps + 1)]), core.q)
    assert "rejected" not in proc.stderr() and "no command for step" not in proc.stderr()


def test_the_sim_command_plays_pauses_and_steps_the_simulator(stepping, ros_context):
    """`tensegrity sim` calls the simulation_interfaces services from the shell: exit 0 on
    OK, 1 with the simulator's code and reason, 2 for a bad command line."""
    import json

    from tests.ros_support import run_cli_here

    clock, spin = _clock_listener(ros_context)
    proc, client = stepping()                                  # free-running, real time
    out = run_cli_here("sim", "pause")
    assert out.returncode == 0 and out.stdout.startswith("ok: playing -> paused"), out.stdout + out.stderr
    paused_at = _standing_clock(clock, spin)
    out = run_cli_here("sim", "step", "3")
    assert out.returncode == 0 and "3 steps done" in out.stdout, out.stdout + out.stderr
    assert _standing_clock(clock, spin, above=paused_at) == paused_at + 3 * STEP_NS
    assert f"t = {(paused_at + 3 * STEP_NS) / 1e9:.9f} s" in out.stdout     # the answer says where it stands
    from simulation_interfaces.msg import SimulationState

    state = json.loads(run_cli_here("sim", "state", "--json").stdout)
    assert state["ok"] and state["state"]["state"] == SimulationState.STATE_PAUSED
    assert run_cli_here("sim", "play").returncode == 0
    out = run_cli_here("sim", "step", "2")
    assert out.returncode == 1 and out.stdout.startswith("failed (RESULT_OPERATION_FAILED)"), out.stdout
    out = run_cli_here("sim", "play")
    assert out.returncode == 0 and "already playing" in out.stdout            # ALREADY_IN_TARGET_STATE
    out = run_cli_here("sim", "step")
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr


def test_the_answer_the_last_step_ran_under_sent_again_is_dropped_not_rejected(stepping):
    """In lockstep a controller answers a republished state again (tensegrity_controller does),
    so the answer of the step just taken can arrive twice: the copy is dropped without a
    warning. A different command with that stamp is still rejected as stamped for another step."""
    from tensegrity_msgs.msg import ActuatorForces

    proc, client = stepping("lockstep:=true", "initial_state:=paused", "paused_publish_rate:=0.0",
                            "lockstep_timeout:=30.0")
    client.set_law(None)
    client.reset_all()
    answer = ActuatorForces(name=["f1", "f2"], force=[0.5, 0.5])   # stamped 0: the state at t = 0
    client.pub.publish(answer)
    client.step(1)                                    # runs under it
    client.wait_joint(STEP_NS)
    client.pub.publish(answer)                        # the same answer again
    other = ActuatorForces(name=["f1", "f2"], force=[0.75, 0.5])
    client.pub.publish(other)                         # a different one for the same, past, state
    deadline = time.monotonic() + 30
    while "rejected actuator command" not in proc.stderr():
        assert time.monotonic() < deadline, proc.stderr()
        time.sleep(0.05)
    assert "stamped 0.000000000 s, but the simulator waits at step 1" in proc.stderr()
    assert proc.stop() == 0
    assert "rejected commands: 1;" in proc.stderr()      # the copy was not counted (nor warned of)


@pytest.mark.parametrize("lockstep", [False, True])
def test_simulate_steps_gives_feedback_after_every_step(stepping, ros_context, lockstep):
    """Issue 33: 25 steps, 25 feedbacks (completed 1..25, remaining 24..0), each kept by the
    server until its reader has it. The client keeps up to 1000 of them and asks for the
    result after the last (rclpy's ActionClient drops feedback it processes after the result)."""
    import rclpy
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from simulation_interfaces.action import SimulateSteps

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard

    proc, client = stepping("initial_state:=paused", "paused_publish_rate:=0.0", f"lockstep:={str(lockstep).lower()}",
                            "lockstep_timeout:=30.0")
    client.set_law(lambda sample: (-0.35, 0.35))
    node = rclpy.create_node("feedback_test", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    action = ActionClient(node, SimulateSteps, "simulate_steps", feedback_sub_qos_profile=QoSProfile(depth=1000))
    assert wait_for_action_server(node, action, 30)
    assert wait_until_server_heard(node, "simulate_steps", lambda f, t: spin_until_done(ex, f, t), 30)
    for _ in range(3):
        feedback: list = []
        goal = action.send_goal_async(SimulateSteps.Goal(steps=25), feedback_callback=lambda m, got=feedback: got.append(
            (m.feedback.completed_steps, m.feedback.remaining_steps)))
        assert spin_until_done(ex, goal, 30) and goal.result().accepted
        deadline = time.monotonic() + 60
        while not feedback or feedback[-1][1] != 0:
            assert time.monotonic() < deadline, feedback
            ex.spin_once(timeout_sec=0.05)
        result = goal.result().get_result_async()
        assert spin_until_done(ex, result, 30) and result.result().result.result.result == 1
        assert feedback == [(k, 25 - k) for k in range(1, 26)]
    # playing, the goal ends with SimulateSteps.action's code for it: "Calling with simulation
    # unpaused will return OPERATION_FAILED and error message"
    from action_msgs.msg import GoalStatus
    from simulation_interfaces.msg import Result, SimulationState

    assert client.set_state(SimulationState.STATE_PLAYING).result.result == Result.RESULT_OK
    goal = action.send_goal_async(SimulateSteps.Goal(steps=5))
    assert spin_until_done(ex, goal, 30) and goal.result().accepted
    result = goal.result().get_result_async()
    assert spin_until_done(ex, result, 30) and result.result().status == GoalStatus.STATUS_ABORTED
    refused = result.result().result.result
    assert refused.result == Result.RESULT_OPERATION_FAILED and "paused" in refused.error_message
    node.destroy_node()
