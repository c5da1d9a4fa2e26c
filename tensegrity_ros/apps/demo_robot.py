"""The demo's robot phase: the 6-bar rolled by its gait over ROS, recorded, rerun identical.

A second ``tensegrity_sim`` runs the scene ``six_bar_rest`` (the 6-bar standing on a face,
its 24 motors taking ``cable_commands``) in the namespace ``/six_bar``, in lockstep and
paused, with the demo's control period as its step. The demo's client answers every
joint state with the rest lengths of the shipped ``six_bar_roll`` gait (cut to its first
``faces`` faces, :func:`.gait_goal.first_faces`) at the state's time, sampled and held for
the step, as the cable controller would command them; the run is recorded to
``OUT/six_bar_roll`` (every topic the simulator publishes, and the commands), then run a
second time and compared stamp by stamp (identical bit for bit: lockstep stepping depends
on no arrival time). What the robot did: distance [m], faces rolled, peak tensions [N]
(:mod:`.roll_summary`, from the client's own subscriptions).
"""

from __future__ import annotations

import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tensegrity_core.robot.gait import Gait
from tensegrity_core.sim.sampled import NS_PER_S
from tensegrity_core.sim.simulator import JointSample

NAMESPACE = "/six_bar"
SCENE = "six_bar_rest"
GAIT = "six_bar_roll"
FACES = 3                 # of the shipped gait's 8: the demo stays short
BAG = "six_bar_roll"


def gait_law(gait: Gait) -> Callable[[JointSample], list[float]]:
    """``law(sample) -> rest lengths [m]``: the gait's rest lengths at the sample's time."""
    laws = [gait.laws()[name] for name in gait.cables]
    return lambda sample: [law.value_at(sample.t, 0.0) for law in laws]


def run_robot(rclpy: Any, out: Path, *, step_ns: int, record: bool, results: dict[str, Any], bags: list[Path],
              say: Callable[[str], None], faces: int = FACES) -> bool:
    """The robot phase (module note); True when the rerun is identical and the bag complete."""
    from tensegrity_core.robot.loading import load_robot
    from tensegrity_ros.apps.gait_goal import first_faces, gait_named
    from tensegrity_ros.apps.gait_run import RunWatcher
    from tensegrity_ros.apps.launch import Launcher, ProcessSpec
    from tensegrity_ros.apps.recording import Recorder
    from tensegrity_ros.apps.sim_client import SimClient
    from tensegrity_ros.bag.completeness import completeness_line
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    robot = load_robot("six_bar")
    speed = {robot.cables.names[j]: float(v) for j, v in zip(robot.cables.actuated, robot.motors.max_speed)}
    gait = gait_named(GAIT)
    gait = first_faces(gait, faces, [speed[c] for c in gait.cables])
    steps = -(-round(gait.duration * NS_PER_S) // step_ns) + round(1.0 * NS_PER_S) // step_ns   # + 1 s to settle
    exe = [sys.executable, "-m", "tensegrity_ros.cli"]
    argv = exe + ["node", "sim", "--ros-args", "-r", f"__ns:={NAMESPACE}", "-p", f"scene:={SCENE}",
                  "-p", "lockstep:=true", "-p", "initial_state:=paused", "-p", f"step_size:={step_ns / NS_PER_S!r}",
                  "-p", f"publish_rate:={NS_PER_S / step_ns!r}", "-p", "paused_publish_rate:=0.0",
                  "-p", "lockstep_timeout:=30.0", "-p", "publish_clock:=false"]
    log = open(out / "six_bar.log", "w")
    launcher = Launcher([ProcessSpec("six_bar", argv)], out=log)
    say(f"the 6-bar robot: {SCENE} in {NAMESPACE}, lockstep at {step_ns / 1e6:g} ms, rolled by the gait {GAIT} "
        f"({faces} faces, {gait.duration:.2f} s, then 1 s to settle; logs in {out / 'six_bar.log'})")
    launcher.start()
    client = SimClient(rclpy, "tensegrity_demo_six_bar", namespace=NAMESPACE, record_events=False,
                       cables=gait.cables)
    watcher = RunWatcher(client.node)
    rec = None
    try:
        client.wait_for_services(120.0)
        law = gait_law(gait)

        def roll() -> list[Any]:
            client.set_law(None)
            client.reset_all()
            client.take_joints()
            client.set_law(law, until_ns=steps * step_ns)
            client.step(steps)
            client.set_law(None)
            client.wait_joint(steps * step_ns)
            return client.take_joints()

        if record:
            folder = out / BAG
            if folder.exists():
                shutil.rmtree(folder)
            published = sorted(name for name, _ in client.node.get_topic_names_and_types()
                               if name.startswith(NAMESPACE + "/") and client.node.count_publishers(name) > 0
                               and not name.endswith("/cable_commands") and "/_" not in name)
            commands_before = client.pub.get_subscription_count()
            rec = Recorder(folder, [*published, f"{NAMESPACE}/cable_commands", "--custom-data", f"scene={SCENE}"])
            state = [t for t in published if not t.endswith("/events")]
            rec.wait_ready(state, client.reset_all, matched={f"{NAMESPACE}/cable_commands": 1}, every=0.2)
            if not wait_for_matches([client.pub], commands_before + 1, 60.0):
                raise RuntimeError("the demo's cable_commands publisher did not match the recorder within 60 s")
            bags.append(folder)
        say("  rolling the 6-bar" + (f" (recording {out / BAG})" if record else ""))
        first = roll()
        window = (0.0, steps * step_ns / NS_PER_S)
        drained = time.monotonic() + 30.0        # the watcher's samples up to the run's end (its own subscriptions)
        while watcher.latest() < window[1] and time.monotonic() < drained:
            time.sleep(0.05)
        complete = True
        if rec is not None:
            stamps = sorted({j.stamp_ns for j in first})
            expected = {f"{NAMESPACE}/joint_states": stamps, f"{NAMESPACE}/body_states": stamps,
                        f"{NAMESPACE}/cable_commands": stamps[:-1]}
            rec.wait_complete(expected)
            code, rec = rec.stop(), None
            complete, line = completeness_line(folder, expected)
            complete = complete and code == 0
            say(f"  bag {folder}: {line}")
        summary = watcher.summary_lines(*window)
        for text in summary:
            say(f"  {text}")
        say("  the roll again, not recorded: same lockstep run, compared stamp by stamp")
        second = roll()
        a, b = {j.stamp_ns: j for j in first}, {j.stamp_ns: j for j in second}
        identical = a == b
        say(f"  second run: {len(b)} joint states, " + ("identical to the first (every cable length, rate and "
                                                        "tension bit for bit)" if identical else "DIFFERENT"))
        results["robot"] = {"identical": identical, "complete": complete, "summary": summary}
        return identical and complete
    finally:
        if rec is not None:
            rec.stop()
        client.close()
        launcher.stop()
        log.close()
