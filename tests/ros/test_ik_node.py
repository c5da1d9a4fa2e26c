"""The solve_ik service of a real tensegrity_ik node, over DDS (issues 6 and 9)."""

from __future__ import annotations

import math

import pytest

from tensegrity_ros.rclpy_utils.futures import spin_until_done
from tensegrity_ros.rclpy_utils.matching import wait_for_service
from tests.ros_support import probe

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def ik_service(tmp_path_factory):
    """A running `tensegrity node ik` process and a client in this process."""
    from tests.ros_support import Proc

    log = tmp_path_factory.mktemp("ik") / "ik.log"
    proc = Proc(["node", "ik"], log)
    proc.wait_for("solve_ik ready")
    from rclpy.qos import QoSProfile
    from tensegrity_msgs.srv import SolveIK

    with probe("ik_test_client") as client_probe:
        # A burst of concurrent calls needs a response history as deep as the burst: rclpy's
        # default keeps the last 10 responses, and the server answers faster than a client
        # takes them (measured: 60-80 of 100 arrive with the default). The server's own queue
        # is deep (SERVICE_QOS), so it never loses a request.
        client = client_probe.node.create_client(SolveIK, "solve_ik", qos_profile=QoSProfile(depth=1000))
        executor = client_probe.executor
        assert wait_for_service(client, 30)

        def call(x, y, seed=()):
            future = client.call_async(SolveIK.Request(x=x, y=y, seed=list(seed)))
            assert spin_until_done(executor, future, 30), "no answer"
            return future.result()

        call.client, call.executor = client, executor
        yield call
    proc.stop()


def _fk(rho1, rho2):
    """Independent forward kinematics (paper parameters): energy-minimising beta."""
    lam1 = math.sqrt(4 - (rho1 + rho2) ** 2)
    beta = math.atan2(lam1, 3 * rho2 - rho1)
    return rho1 + math.cos(beta), math.sin(beta), beta


def test_answers_reach_the_target_and_match_the_core(ik_service):
    from tensegrity_core.class2 import inverse_kinematics

    x0, y0, _ = _fk(0.7, 0.7)
    res = ik_service(x0, y0)
    assert res.success, res.message
    assert len(res.solutions) == 1
    s = res.solutions[0]
    assert (s.rho1, s.rho2) == pytest.approx((0.7, 0.7), abs=1e-10)
    core = inverse_kinematics(x0, y0).valid
    assert [(c.rho1, c.rho2, c.beta) for c in core] == [(s.rho1, s.rho2, s.beta)]
    assert s.in_paper_range and s.stiffness_beta > 0
    assert (s.delta1, s.delta2) == (core[0].delta1, core[0].delta2)


def test_the_folded_pose_is_returned_with_its_singular_set_named(ik_service):
    """D = (0, L) is reached only by the paper's q_F = [0, 0, pi/2] (Sect. 5.3: "a singular
    configuration"): an equilibrium, returned as such, with the set the controller's refusal
    of the same target names (tests/ros/test_controller_node.py)."""
    res = ik_service(0.0, 1.0)
    assert res.success, res.message
    [s] = res.solutions
    assert (s.rho1, s.rho2, s.beta) == pytest.approx((0.0, 0.0, math.pi / 2), abs=1e-12)
    assert s.singular_set == "folded" and s.singularity_distance == 0.0
    assert "lies on the singular set folded" in res.message


def test_seed_orders_and_measures_distance(ik_service):
    x, y, _ = _fk(0.3, 0.9)
    res = ik_service(x, y, seed=(0.0, 0.0))
    assert res.success
    s = res.solutions[0]
    assert s.distance_to_seed == pytest.approx(math.hypot(s.rho1, s.rho2), rel=1e-12)


@pytest.mark.parametrize("x, y, why", [
    (5.0, 0.5, "outside the workspace"),
    (0.5, 1.5, "|y| > L"),
    (0.5, -0.3, "no valid solution"),
])
def test_unreachable_targets_fail_with_a_reason(ik_service, x, y, why):
    res = ik_service(x, y)
    assert not res.success and not res.solutions
    assert why in res.message


@pytest.mark.parametrize("x, y, seed", [
    (math.nan, 0.5, ()), (0.5, math.inf, ()), (1.0, 0.5, (0.1,)), (1.0, 0.5, (0.1, 0.2, 0.3)),
    (1.0, 0.5, (math.nan, 0.2)),
])
def test_malformed_requests_fail_cleanly(ik_service, x, y, seed):
    res = ik_service(x, y, seed)
    assert not res.success and res.message
    if not all(math.isfinite(v) for v in (x, y, *seed)):     # every number with its unit
        assert res.message == f"non-finite request: x = {x:g} m, y = {y:g} m, seed = {list(seed)} m"
    # the node is still alive and answering
    x0, y0, _ = _fk(0.5, 0.5)
    assert ik_service(x0, y0).success


def test_one_hundred_concurrent_calls_all_answered(ik_service):
    from tensegrity_msgs.srv import SolveIK

    targets = [(_fk(0.2 + 0.005 * k, 0.6)[:2]) for k in range(100)]
    futures = [ik_service.client.call_async(SolveIK.Request(x=x, y=y)) for x, y in targets]
    for f in futures:
        spin_until_done(ik_service.executor, f, 60)
    assert all(f.done() for f in futures)
    for k, f in enumerate(futures):
        res = f.result()
        assert res.success, res.message
        assert res.solutions[0].rho1 == pytest.approx(0.2 + 0.005 * k, abs=1e-9)
        assert res.solutions[0].rho2 == pytest.approx(0.6, abs=1e-9)


def test_bad_and_good_calls_interleaved_concurrently_all_answered(ik_service):
    """100 calls in flight at once, every third malformed (NaN, seed of the wrong length,
    unreachable): each gets its own answer, the bad ones success = false with a reason,
    the good ones the right lengths (issue 9: services keep answering other callers)."""
    from tensegrity_msgs.srv import SolveIK

    requests = []
    for k in range(100):
        x, y = _fk(0.2 + 0.005 * k, 0.6)[:2]
        kind = ("good", "nan", "seed", "unreachable")[k % 4] if k % 3 == 0 else "good"
        if kind == "nan":
            x = math.nan
        seed = [0.1] if kind == "seed" else []
        if kind == "unreachable":
            y = 1.5
        requests.append((kind, k, SolveIK.Request(x=x, y=y, seed=seed)))
    futures = [ik_service.client.call_async(req) for _, _, req in requests]
    for f in futures:
        spin_until_done(ik_service.executor, f, 60)
    assert all(f.done() for f in futures)
    for (kind, k, _), f in zip(requests, futures):
        res = f.result()
        if kind == "good":
            assert res.success and res.solutions[0].rho1 == pytest.approx(0.2 + 0.005 * k, abs=1e-9)
        else:
            assert not res.success and res.message and not res.solutions
            assert {"nan": "non-finite", "seed": "seed must be", "unreachable": "|y| > L"}[kind] in res.message
