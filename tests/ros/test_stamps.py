"""``stamp_ns``: a ``builtin_interfaces`` Time or Duration as integer nanoseconds, read as
rclpy reads it (``Time.from_msg``, ``Duration.from_msg``: the independent oracle), exact
over the whole range of the fields (int32 seconds, uint32 nanoseconds)."""

from __future__ import annotations

import pytest

pytest.importorskip("rclpy")

from builtin_interfaces.msg import Duration as DurationMsg  # noqa: E402
from builtin_interfaces.msg import Time as TimeMsg  # noqa: E402
from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from rclpy.duration import Duration  # noqa: E402
from rclpy.time import Time  # noqa: E402

from tensegrity_ros.rclpy_utils.messages import stamp_ns, stamp_to_s  # noqa: E402

INT32 = st.integers(-2**31, 2**31 - 1)
UINT32 = st.integers(0, 2**32 - 1)


@pytest.mark.parametrize("sec, nanosec, ns", [
    (0, 0, 0),
    (1, 999_999_999, 1_999_999_999),
    (-1, 500_000_000, -500_000_000),                     # a Duration of -0.5 s
    (2**31 - 1, 999_999_999, 2_147_483_647_999_999_999),  # the latest Time: beyond a float's 53 bits
    (0, 2**32 - 1, 4_294_967_295),                       # nanosec over 1e9 adds whole seconds
    (-2**31, 0, -2_147_483_648_000_000_000),
])
def test_edges(sec, nanosec, ns):
    assert stamp_ns(DurationMsg(sec=sec, nanosec=nanosec)) == ns
    assert stamp_ns(TimeMsg(sec=sec, nanosec=nanosec)) == ns


@given(sec=INT32, nanosec=UINT32)
def test_a_duration_as_rclpy_reads_it(sec, nanosec):
    assert stamp_ns(DurationMsg(sec=sec, nanosec=nanosec)) == Duration.from_msg(
        DurationMsg(sec=sec, nanosec=nanosec)).nanoseconds


@given(sec=st.integers(0, 2**31 - 1), nanosec=st.integers(0, 999_999_999))
def test_a_time_as_rclpy_reads_it_and_as_seconds(sec, nanosec):
    msg = TimeMsg(sec=sec, nanosec=nanosec)
    ns = stamp_ns(msg)
    assert ns == Time.from_msg(msg).nanoseconds
    assert abs(ns / 1e9 - stamp_to_s(msg)) <= 2 ** -50 * max(sec, 1)     # the float agrees to a few of its ulps
