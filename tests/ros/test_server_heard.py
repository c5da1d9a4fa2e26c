"""wait_until_server_heard over real DDS on loopback: an rclpy action server in a participant
of its own (a second context), with and without parameter services."""

from __future__ import annotations

from contextlib import contextmanager

import pytest

from tests.ros_support import probe


@contextmanager
def _action_server(parameter_services: bool):
    """A SimulateSteps server that succeeds at once, spun on a thread of its own."""
    from rclpy.action import ActionServer
    from simulation_interfaces.action import SimulateSteps

    def execute(handle):
        handle.succeed()
        return SimulateSteps.Result()

    with probe("heard_server", spin=True, start_parameter_services=parameter_services) as server:
        ActionServer(server.node, SimulateSteps, "heard_steps", execute)
        yield


@pytest.mark.parametrize("parameter_services", [True, False])
def test_a_server_is_heard_only_through_its_parameter_services(ros_context, parameter_services):
    """With parameter services the probe is answered (True) and the goal sent after it is
    accepted; without them nothing can prove the match (False, at once), and the probe
    client is gone from the node either way."""
    import rclpy
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from simulation_interfaces.action import SimulateSteps

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard

    with _action_server(parameter_services):
        node = rclpy.create_node("heard_client", context=ros_context)
        ex = SingleThreadedExecutor(context=ros_context)
        ex.add_node(node)
        action = ActionClient(node, SimulateSteps, "heard_steps")
        assert wait_for_action_server(node, action, 60)
        heard = wait_until_server_heard(node, "heard_steps", lambda f, t: spin_until_done(ex, f, t), 60)
        assert heard is parameter_services
        assert not any(name.endswith("/get_parameters")
                       for name, _types in node.get_client_names_and_types_by_node("heard_client", "/"))
        goal = action.send_goal_async(SimulateSteps.Goal(steps=1))
        assert spin_until_done(ex, goal, 60) and goal.result().accepted
        action.destroy()
        ex.shutdown()
        node.destroy_node()


def test_server_waits_find_a_server_and_give_up_without_one(ros_context):
    """``wait_for_service``: True once a server in another participant is there, False after
    its timeout when none is, and False once the client's context is shut down (no wait past
    it); ``wait_for_action_server`` False after its timeout and after the shutdown (its True
    path: test_a_server_is_heard_only_through_its_parameter_services). ~1 s."""
    import rclpy
    from rclpy.action import ActionClient
    from simulation_interfaces.action import SimulateSteps
    from std_srvs.srv import Trigger

    from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_for_service

    node = rclpy.create_node("wait_for_service_client", context=ros_context)
    absent = node.create_client(Trigger, "no_such_service")
    absent_action = ActionClient(node, SimulateSteps, "no_such_action")
    assert wait_for_service(absent, 0.2) is False
    assert wait_for_action_server(node, absent_action, 0.2) is False
    with probe("wait_for_service_server", spin=True) as server:
        server.node.create_service(Trigger, "present_service", lambda _req, res: res)
        assert wait_for_service(node.create_client(Trigger, "present_service"), 60.0) is True
    rclpy.try_shutdown(context=ros_context)
    assert wait_for_service(absent, 60.0) is False
    assert wait_for_action_server(node, absent_action, 60.0) is False
