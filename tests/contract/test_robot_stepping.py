"""``simulation_interfaces`` on a robot, called as the standard's client calls it: the 6-bar of
``six_bar_drop`` (dropped from 5 cm: about 0.1 s of free fall) started paused with 1 ms steps.

Expectations from the standard (simulation_interfaces 1.5.1): stepping works on a paused
simulator and advances ``/clock`` by exactly steps x step size, is refused while playing with
RESULT_OPERATION_FAILED (StepSimulation.srv: "Calling with simulation not paused will return
RESULT_OPERATION_FAILED and error message") and a message; a transition to the current state answers
ALREADY_IN_TARGET_STATE; a reset (SCOPE_DEFAULT) puts the clock at 0 and the robot back
where it started; the state getter says which state the simulator is in. And, stepped into
its free fall, every rod's IMU reads what a real one does there: no specific force and no
rotation (sensor_msgs/Imu's linear_acceleration includes gravity; a falling body feels none).
"""

from __future__ import annotations

import pytest

from tests.contract.client import Client, stamp_ns, start_sim

pytestmark = pytest.mark.ros

STEP_NS = 1_000_000
RODS = [f"rod{i}" for i in range(6)]      # six_bar.yaml's rods, each with an IMU


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Imu
    from tensegrity_msgs.msg import RigidBodyStates

    sim = start_sim(tmp_path_factory.mktemp("stepping"), "six_bar_drop", "initial_state:=paused",
                    f"step_size:={STEP_NS / 1e9}", "paused_publish_rate:=20.0", "marker_rate:=0.0")
    client = Client("stepping_client")
    try:
        client.listen(Clock, "/clock", QoSProfile(depth=1000))
        client.listen(RigidBodyStates, "body_states", QoSProfile(depth=1000))
        for rod in RODS:
            client.listen(Imu, f"imu/{rod}", QoSProfile(depth=1000))
        yield client
    finally:
        client.close()
        sim.stop()


def _state(client) -> int:
    from simulation_interfaces.srv import GetSimulationState

    answer = client.call(GetSimulationState, "get_simulation_state")
    return answer.state.state


def _set(client, state: int):
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import SetSimulationState

    return client.call(SetSimulationState, "set_simulation_state",
                       SetSimulationState.Request(state=SimulationState(state=state))).result


def _step(client, steps: int):
    from simulation_interfaces.srv import StepSimulation

    return client.call(StepSimulation, "step_simulation", StepSimulation.Request(steps=steps)).result


def _poses_at(client, ns: int, after: int = 0):
    """The rods' poses of a body_states message stamped ``ns``, received after the first ``after``."""
    def found():
        return next((m for m in client.received["body_states"][after:] if stamp_ns(m.header.stamp) == ns), None)

    msg = client.wait(found, f"body_states stamped {ns} ns")
    return [(p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z,
             p.orientation.w) for p in msg.pose]


def test_stepping_a_paused_robot_advances_the_clock_by_whole_steps_and_a_reset_puts_it_back(suite):
    from simulation_interfaces.msg import Result, SimulationState
    from simulation_interfaces.srv import ResetSimulation, SetSimulationState

    client = suite
    assert _state(client) == SimulationState.STATE_PAUSED
    start = _poses_at(client, 0)
    answer = _step(client, 30)
    assert answer.result == Result.RESULT_OK, answer.error_message
    client.wait(lambda: any(stamp_ns(m.clock) == 30 * STEP_NS for m in client.received["/clock"]),
                "/clock at 30 steps")
    seen = len(client.received["/clock"])
    client.wait_count("/clock", 3)                # republished while paused: time stands
    assert {stamp_ns(m.clock) for m in client.received["/clock"][seen:]} == {30 * STEP_NS}
    for rod in RODS:                              # 30 ms into a 0.1 s fall
        imu = client.wait(lambda rod=rod: client.stamped[f"imu/{rod}"].get(30 * STEP_NS), f"imu/{rod} at 30 ms")
        a, w = imu.linear_acceleration, imu.angular_velocity
        assert max(abs(a.x), abs(a.y), abs(a.z)) < 0.05 and max(abs(w.x), abs(w.y), abs(w.z)) < 1e-3, (rod, a, w)
    assert _set(client, SimulationState.STATE_PAUSED).result == SetSimulationState.Response.ALREADY_IN_TARGET_STATE

    assert _set(client, SimulationState.STATE_PLAYING).result == Result.RESULT_OK
    assert _state(client) == SimulationState.STATE_PLAYING
    refused = _step(client, 1)
    assert refused.result == Result.RESULT_OPERATION_FAILED and refused.error_message.strip()

    assert _set(client, SimulationState.STATE_PAUSED).result == Result.RESULT_OK
    seen = len(client.received["body_states"])
    reset = client.call(ResetSimulation, "reset_simulation",
                        ResetSimulation.Request(scope=ResetSimulation.Request.SCOPE_DEFAULT))
    assert reset.result.result == Result.RESULT_OK, reset.result.error_message
    assert _poses_at(client, 0, after=seen) == start                  # the robot where it started, at t = 0
