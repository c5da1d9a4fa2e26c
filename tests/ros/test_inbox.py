"""Inbox: messages already received are handed on by ``take_queued`` from any thread, each
once and in order, also while another thread waits on the inbox (real DDS on loopback).

This is what a stepping request relies on in the simulator: a command its reader has
received before the request counts for the step, whether or not the command thread has
taken it yet."""

from __future__ import annotations

import threading

import pytest

pytestmark = pytest.mark.ros

COUNT = 50


def _setup(ctx, name: str):
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from std_msgs.msg import Int32

    from tensegrity_ros.rclpy_utils.inbox import Inbox
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    node = Node(f"{name}_inbox", context=ctx)
    seen: list[tuple[int, str]] = []
    inbox = Inbox(node)
    inbox.subscribe(Int32, f"{name}_topic", lambda m: seen.append((m.data, threading.current_thread().name)),
                    QoSProfile(depth=COUNT))
    talker = Node(f"{name}_talker", context=ctx)
    pub = talker.create_publisher(Int32, f"{name}_topic", QoSProfile(depth=COUNT))
    assert wait_for_matches([pub], 1, 30)
    return node, talker, pub, inbox, seen


def test_take_queued_hands_on_every_received_message_at_once_without_waiting(ros_context):
    from rclpy.duration import Duration
    from std_msgs.msg import Int32

    node, talker, pub, inbox, seen = _setup(ros_context, "queued")
    try:
        for i in range(COUNT):
            pub.publish(Int32(data=i))
        assert pub.wait_for_all_acked(Duration(seconds=30))       # all of them are in the reader
        assert inbox.take_queued() == COUNT
        assert [value for value, _ in seen] == list(range(COUNT))
        assert inbox.take_queued() == 0                           # nothing is handed on twice
    finally:
        talker.destroy_node()
        node.destroy_node()


def test_take_queued_beside_a_waiting_thread_hands_each_message_on_once_in_order(ros_context):
    from rclpy.duration import Duration
    from std_msgs.msg import Int32

    node, talker, pub, inbox, seen = _setup(ros_context, "beside")
    stop = threading.Event()

    def waiter() -> None:
        while not stop.is_set():
            inbox.wait(0.05)

    thread = threading.Thread(target=waiter, name="waiter")
    thread.start()
    try:
        for i in range(COUNT):
            pub.publish(Int32(data=i))
            if i % 5 == 4:
                assert pub.wait_for_all_acked(Duration(seconds=30))
                inbox.take_queued()
                # everything received up to now has been handed on, by one thread or the other
                assert [value for value, _ in seen] == list(range(i + 1))
    finally:
        stop.set()
        inbox.wake()
        thread.join(10)
        talker.destroy_node()
        node.destroy_node()
    assert not thread.is_alive()
