"""wait_until_subscribers_heard over real DDS on loopback: subscribing nodes in participants
of their own (second contexts), asked through their parameter services."""

from __future__ import annotations

import pytest

from tests.ros_support import probe

pytestmark = pytest.mark.ros


def _publisher(ros_context):
    """A node of this test's participant publishing on ``heard_topic``, its executor and the publisher."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Empty

    node = rclpy.create_node("heard_publisher", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    return node, ex, node.create_publisher(Empty, "heard_topic", 10)


@pytest.mark.parametrize("spun", [True, False])
def test_every_subscriber_with_parameter_services_must_answer(ros_context, spun):
    """Two subscribing nodes: one without parameter services (passed over: nothing can prove
    its match) and one with them. Spun, the latter answers and the wait is True; not spun,
    nothing answers it and the wait is False once its time is up. Either way the probe
    clients are gone from the node."""
    from std_msgs.msg import Empty

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches, wait_until_subscribers_heard

    with probe("heard_mute", spin=True, start_parameter_services=False) as mute, \
            probe("heard_asked", spin=spun) as asked:
        for p in (mute, asked):
            p.node.create_subscription(Empty, "heard_topic", lambda _m: None, 10)
        node, ex, pub = _publisher(ros_context)
        try:
            assert wait_for_matches([pub], 2, 60)
            # not spun: 3 s of asking, which no load can answer (nothing takes the requests)
            heard = wait_until_subscribers_heard(node, [pub], lambda f, t: spin_until_done(ex, f, t),
                                                 60 if spun else 3)
            assert heard is spun
            assert not any(name.endswith("/get_parameters")
                           for name, _types in node.get_client_names_and_types_by_node("heard_publisher", "/"))
        finally:
            ex.shutdown()
            node.destroy_node()


def test_a_stop_request_ends_the_wait(ros_context):
    """``should_stop`` ends the asking between two attempts: False after the second, not at
    the timeout (600 s)."""
    from std_msgs.msg import Empty

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches, wait_until_subscribers_heard

    with probe("heard_silent") as silent:           # not spun: never answers
        silent.node.create_subscription(Empty, "heard_topic", lambda _m: None, 10)
        node, ex, pub = _publisher(ros_context)
        try:
            assert wait_for_matches([pub], 1, 60)
            asked = []

            def wait(future, seconds):
                asked.append(seconds)
                return spin_until_done(ex, future, min(seconds, 0.2))

            assert not wait_until_subscribers_heard(node, [pub], wait, 600, attempt_s=0.2,
                                                    should_stop=lambda: len(asked) >= 2)
            assert len(asked) == 2
        finally:
            ex.shutdown()
            node.destroy_node()
