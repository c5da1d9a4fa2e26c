"""The find_form service of a real tensegrity_formfind node, over DDS (issues 6 and 9)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from tensegrity_core.general import example_path
from tensegrity_ros.rclpy_utils.futures import wait_done
from tensegrity_ros.rclpy_utils.matching import wait_for_service
from tests.ros_support import probe

pytestmark = pytest.mark.ros

TABLE = example_path("tensegrity_table").read_text()


def test_the_service_definition_gives_the_eigenvalue_unit_the_cli_prints():
    """A client reads units from FindForm.srv: with rigid bodies the tangent stiffness mixes
    N/m with N m/rad, as `tensegrity formfind` and `call-formfind` print (no DDS, ~1 ms)."""
    from pathlib import Path

    from tensegrity_core.general import load_example
    from tensegrity_ros.cli.cmd_formfind import k_unit

    srv = (Path(__file__).parents[2] / "msgs_spec/tensegrity_msgs/srv/FindForm.srv").read_text()
    comment = srv[srv.index("min_stiffness_eigenvalue"):srv.index("float64 stability_margin")]
    assert k_unit(load_example("tensegrity_table")) == "N/m and N m/rad mixed"
    assert "N/m" in comment and "N m/rad" in comment


def test_the_service_definition_names_every_format_the_service_reads():
    """FindForm.srv, the node's docstring and the manual's interface table name every format
    the description reader accepts (TOML too), and the manual says how each is told (no DDS)."""
    import ast
    from pathlib import Path

    from tensegrity_core.schema.documents import FORMATS

    root = Path(__file__).parents[2]
    node_doc = ast.get_docstring(ast.parse((root / "tensegrity_ros/nodes/formfind.py").read_text()))
    srv = (root / "msgs_spec/tensegrity_msgs/srv/FindForm.srv").read_text()
    field = srv[srv.index("string structure"):srv.index("float64 tolerance")]
    table = next(line for line in (root / "docs/ros.md").read_text().splitlines()
                 if line.startswith("| `srv/FindForm`"))
    for text in (field, node_doc or "", table):
        assert all(fmt.upper() in " ".join(text.split()) for fmt in FORMATS), text
    assert "docs/ros.md" in field


@pytest.fixture(scope="module")
def formfind(tmp_path_factory):
    """A running `tensegrity node formfind` process (time limit 5 s) and a client here."""
    from rclpy.qos import QoSProfile
    from tensegrity_msgs.srv import FindForm

    from tests.ros_support import Proc

    log = tmp_path_factory.mktemp("ff") / "ff.log"
    proc = Proc(["node", "formfind", "--ros-args", "-p", "time_limit:=5.0",
                 "-p", "max_request_bytes:=1000000"], log)
    proc.wait_for("find_form ready")
    with probe("ff_test_client", multithreaded=True, spin=True) as client_probe:
        client = client_probe.node.create_client(FindForm, "find_form", qos_profile=QoSProfile(depth=100))
        assert wait_for_service(client, 30)

        def call(text, tol=0.0, max_iter=0, timeout=60.0):
            future = client.call_async(FindForm.Request(structure=text, tolerance=tol, max_iterations=max_iter))
            assert wait_done(future, timeout), "no answer"
            return future.result()

        call.client = client
        call.log = proc.stderr
        yield call
    proc.stop()


def test_table_example_gives_the_papers_self_stress(formfind):
    res = formfind(TABLE)
    assert res.success, res.message
    t = np.array(res.member_forces)
    # Ma et al. Eq. 91: forces proportional to [1, 1, 1, 3] (three long strings, one short)
    np.testing.assert_allclose(t / t[0], [1, 1, 1, 3], rtol=1e-8)
    assert res.min_stiffness_eigenvalue > 0 and res.stability_margin > 1
    assert len(res.nodes) == 8
    # the residual is relative (out-of-balance force over the forces at a node), its norm in N
    assert 0 <= res.residual <= 1e-10 and 0 <= res.residual_norm <= 1e-10 * 7.6e6


TABLE_TOML = """name = "tensegrity table"
[defaults]
E = 7.6e10
A = 1.0e-4
type = "string"
rest_length_ratio = 0.3
[nodes]
f1 = [0.0, 1.0, 0.0]
f2 = [-0.8660254037844386, -0.5, 0.0]
f3 = [0.8660254037844386, -0.5, 0.0]
post = [0.0, 0.0, 0.75]
c1 = [0.0, 1.0, 1.0]
c2 = [-0.8660254037844386, -0.5, 1.0]
c3 = [0.8660254037844386, -0.5, 1.0]
hang = [0.0, 0.0, 0.25]
[[members]]
name = "long1"
nodes = ["f1", "c1"]
[[members]]
name = "long2"
nodes = ["f2", "c2"]
[[members]]
name = "long3"
nodes = ["f3", "c3"]
[[members]]
name = "short"
nodes = ["hang", "post"]
[[rigid_bodies]]
name = "bottom"
nodes = ["f1", "f2", "f3", "post"]
[[rigid_bodies]]
name = "top"
nodes = ["c1", "c2", "c3", "hang"]
"""


def test_a_toml_description_is_read_as_the_service_definition_says(formfind):
    """The table written as TOML (FindForm.srv: YAML, JSON or TOML) gives Ma et al.'s
    [1, 1, 1, 3] self-stress, as the YAML example does."""
    res = formfind(TABLE_TOML)
    assert res.success, res.message
    t = np.array(res.member_forces)
    np.testing.assert_allclose(t / t[0], [1, 1, 1, 3], rtol=1e-8)


def test_the_tolerance_is_on_the_relative_residual(formfind):
    """A loose tolerance stops early: the answer's residual lies between the tolerance of the
    request and a tight run's, and its norm says how many newtons that is."""
    shorter = TABLE.replace("- {name: long1, nodes: [f1, c1]}", "- {name: long1, nodes: [f1, c1], rest_length_ratio: 0.25}")
    tight, loose = formfind(shorter), formfind(shorter, tol=1e-3)
    assert tight.success and loose.success, (tight.message, loose.message)
    assert tight.residual <= 1e-10 < loose.residual <= 1e-3
    assert loose.residual_norm > tight.residual_norm and loose.iterations < tight.iterations


def test_call_formfind_prints_the_relative_residual_its_norm_and_the_margin(formfind):
    from tests.ros_support import run_cli_here

    # in this process (no interpreter start, ~1.5 s of CPU): the claim is what the command prints
    out = run_cli_here("call-formfind", "tensegrity_table")
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("ok: converged to a stable equilibrium")
    assert "(relative; norm " in out.stdout and " N, N m), min stiffness eigenvalue " in out.stdout
    assert " N/m and N m/rad mixed, stability margin " in out.stdout        # the table has rigid bodies
    margin = float(out.stdout.split("stability margin ")[1].split()[0])
    assert margin > 1
    # each force under the description's member name; the table's is t = EA (l - l0)/l0 with
    # l0 = 0.3 l: long strings 0.72 m, short 0.78 m at its equilibrium (docs/general.md)
    forces = dict(line.strip().split(": ") for line in out.stdout.splitlines() if line.strip().startswith("member "))
    expected = {"long1": 0.72, "long2": 0.72, "long3": 0.72, "short": 0.78}
    assert sorted(forces) == sorted(f"member {n}" for n in expected)
    for name, l in expected.items():
        l0 = 0.3 * {"short": 0.5}.get(name, 1.0)
        assert float(forces[f"member {name}"].split()[0]) == pytest.approx(7.6e6 * (l - l0) / l0, rel=1e-3)


@pytest.mark.parametrize("text, why", [
    ("nodes: [[0, 0, 0]\n  members: oops", "line"),                       # malformed YAML
    ("nodes: {a: [0,0,0], b: [1,0,0]}\nmembers:\n  - {nodes: [a, zz], EA: 1, rest_length: 1}", "zz"),
    ("nodes: {a: [0,0,0], b: [1,0]}\nmembers:\n  - {nodes: [a, b], EA: 1, rest_length: 1}", "b"),
    ("", "empty"),
])
def test_bad_descriptions_are_refused_with_a_reason(formfind, text, why):
    res = formfind(text)
    assert not res.success
    assert why in res.message


@pytest.mark.parametrize("tol", [-1.0, math.nan, math.inf])
def test_a_tolerance_not_finite_and_at_least_0_is_refused_by_its_field_name(formfind, tol):
    """The request's field is ``tolerance``: an infinite one was passed on and refused as
    "tol (relative residual) must be finite", a name the caller never wrote."""
    res = formfind(TABLE, tol=tol)
    assert not res.success
    assert res.message == f"tolerance must be a finite number >= 0 (0 = default), got {tol}"


def test_very_large_request_is_refused_before_parsing(formfind):
    res = formfind("# " + "x" * 1_100_000 + "\n" + TABLE)
    assert not res.success and "max_request_bytes" in res.message


def test_structure_without_equilibrium_is_a_failure(formfind):
    # The free-floating table (no supports) with a net external load: nothing can balance
    # the load, so there is no equilibrium at all; the service must say so, not "converge".
    res = formfind(TABLE + "loads: {c1: [0, 0, -10]}\n")
    assert not res.success, res.message
    assert res.message


def test_ten_concurrent_calls_complete_while_another_caller_is_served(formfind):
    from tensegrity_msgs.srv import FindForm

    futures = [formfind.client.call_async(FindForm.Request(structure=TABLE)) for _ in range(10)]
    quick = formfind("nodes: {a: [0,0,0]}\nmembers: []")      # another caller, answered meanwhile
    assert not quick.success or quick.message
    deadline = time.monotonic() + 120
    while not all(f.done() for f in futures) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert all(f.done() for f in futures)
    assert all(f.result().success for f in futures)


def test_a_long_request_neither_blocks_others_nor_runs_past_its_time_limit(formfind):
    from tensegrity_msgs.srv import FindForm

    from tensegrity_core.general import dump_structure, tensegrity_spine

    # A 4,800-member spine with 100000 iterations allowed takes longer than the node's
    # time_limit (5 s here), which must stop it.
    spine = dump_structure(tensegrity_spine(600, shape="C"))
    slow = formfind.client.call_async(FindForm.Request(structure=spine, max_iterations=100000))
    time.sleep(0.5)
    t0 = time.monotonic()
    quick = formfind(TABLE)
    quick_done = time.monotonic()
    assert quick.success
    assert not slow.done(), "the slow request should still be running"
    deadline = time.monotonic() + 60
    while not slow.done() and time.monotonic() < deadline:
        time.sleep(0.05)
    res = slow.result()
    assert not res.success and "time limit of 5 s" in res.message
    assert quick_done - t0 < time.monotonic() - t0  # the quick answer came first


def test_unbalanced_structure_says_there_is_no_equilibrium(formfind):
    res = formfind(TABLE + "loads: {c1: [0, 0, -10]}\n")
    assert not res.success and res.iterations == 0
    assert "no equilibrium exists" in res.message and "[0, 0, -10] N" in res.message


def test_bad_requests_among_concurrent_good_ones_each_get_their_own_answer(formfind):
    """Ten calls in flight: valid tables, malformed YAML, an unknown node, inconsistent
    sizes and an unbalanced table; every one answered, each with its own verdict."""
    from tensegrity_msgs.srv import FindForm

    cases = [(TABLE, None), ("nodes: [[0, 0, 0]\n  members: oops", "line"), (TABLE, None),
             ("nodes: {a: [0,0,0], b: [1,0,0]}\nmembers:\n  - {nodes: [a, zz], EA: 1, rest_length: 1}", "zz"),
             (TABLE, None), ("nodes: {a: [0,0,0], b: [1,0]}\nmembers:\n  - {nodes: [a, b], EA: 1, rest_length: 1}",
                             "list of 3 numbers"),
             (TABLE + "loads: {c1: [0, 0, -10]}\n", "no equilibrium exists"), (TABLE, None), (TABLE, None),
             (TABLE, None)]
    futures = [formfind.client.call_async(FindForm.Request(structure=text)) for text, _ in cases]
    deadline = time.monotonic() + 120
    while not all(f.done() for f in futures) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert all(f.done() for f in futures)
    for (_, why), f in zip(cases, futures):
        res = f.result()
        if why is None:
            assert res.success, res.message
            np.testing.assert_allclose(np.array(res.member_forces) / res.member_forces[0], [1, 1, 1, 3], rtol=1e-8)
        else:
            assert not res.success and why in res.message
