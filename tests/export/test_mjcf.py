"""The MJCF document itself (no MuJoCo needed): every element as docs/mujoco.md maps it, with
numbers computed here by hand from the structure; the default time step from closed forms;
what cannot be exported."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.export import ExportError, export_mjcf
from tensegrity_core.export.timestep import DENSE_DOF, largest_eigenvalue_magnitude, round_down_125
from tensegrity_core.general import RigidBody, Structure, load_example
from tensegrity_core.general.writing import structure_to_dict
from tensegrity_core.sim import load_scene, scene_from_dict
from tensegrity_core.sim.general.mjcf import INERTIA_MARGIN


def floats(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()])


def small_structure() -> Structure:
    """One node of each kind: ``p`` pinned, ``r`` a roller (z pinned), ``f`` free, a moving
    triangle ``b1 b2 b3`` and a fixed triangle ``g1 g2 g3``; a string, a bar and an actuator."""
    nodes = {"p": [0, 0, 0], "r": [2, 0, 0], "f": [1, 1, 1], "b1": [0, 0, 2], "b2": [1, 0, 2], "b3": [0, 2, 2],
             "g1": [3, 3, 0], "g2": [4, 3, 0], "g3": [3, 4, 0]}
    names = list(nodes)
    pairs = [("p", "f"), ("r", "f"), ("f", "b1"), ("b2", "g1"), ("b3", "r")]
    pinned = np.zeros((len(names), 3), dtype=bool)
    pinned[names.index("p")] = True
    pinned[names.index("r"), 2] = True
    return Structure.from_arrays(
        [nodes[n] for n in names], [[names.index(a), names.index(b)] for a, b in pairs],
        EA=[100.0, 200.0, 300.0, 400.0, 500.0], rest_length_ratio=[0.9, 1.0, 1.0, 0.95, 1.0],
        kinds=["string", "bar", "string", "string", "actuator"], node_names=names,
        member_names=["s_pf", "bar_rf", "s_fb", "s_bg", "act_br"], pinned=pinned,
        bodies=[RigidBody("tri", (3, 4, 5), 3.0), RigidBody("ground", (6, 7, 8), 1.0, fixed=True)],
        node_masses=[0.0, 0.5, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0], member_masses=[0.2, 0.4, 0.6, 0.0, 0.0],
        name="small")


def small_scene(**changes):
    data = {"name": "small", "model": {"kind": "general", "structure": structure_to_dict(small_structure())},
            "initial": {"drawn": True}, "inputs": {"act_br": 2.0},
            "effects": ["inertia", "springs", {"damping": {"c": 0.7}}, {"gravity": {"vector": [0, 0, -9.0]}},
                        {"loads": {"f": [3.0, 0.0, 4.0], "b3": [0.0, -2.0, 0.0], "p": [1.0, 1.0, 1.0]}}],
            "duration": 1.0}
    data.update(changes)
    return scene_from_dict(data)


def test_every_element_maps_as_documented():
    s = small_structure()
    root = ET.fromstring(export_mjcf(small_scene(), timestep=1e-3).xml)
    world = root.find("worldbody")
    assert floats(root.find("option").get("gravity")).tolist() == [0.0, 0.0, -9.0]
    assert root.find("option/flag").get("contact") == "disable"
    # pinned nodes and the fixed body's nodes: world sites where they are drawn
    for name in ("p", "g1", "g2", "g3"):
        site = world.find(f"site[@name='node:{name}']")
        assert floats(site.get("pos")).tolist() == s.nodes[s.node_index(name)].tolist()
    # free and partially pinned nodes: point masses on slide joints of their free axes.
    # Lumped masses by hand: f = 2 + (0.2 + 0.4 + 0.6) / 2, r = 0.5 + 0.4 / 2.
    for name, axes, mass in (("f", "xyz", 2.6), ("r", "xy", 0.7)):
        body = world.find(f"body[@name='node:{name}']")
        assert floats(body.get("pos")).tolist() == s.nodes[s.node_index(name)].tolist()
        assert [j.get("name") for j in body.findall("joint")] == [f"node:{name}:{a}" for a in axes]
        assert all(j.get("type") == "slide" for j in body.findall("joint"))
        assert float(body.find("inertial").get("mass")) == pytest.approx(mass, rel=1e-15)
    # the moving triangle: 3 kg shared equally, 1 kg on b1, 0.3 kg (half of s_fb) on b1
    body = world.find("body[@name='body:tri']")
    assert body.find("freejoint").get("name") == "body:tri"
    centroid = np.array([1 / 3, 2 / 3, 2.0])
    assert floats(body.get("pos")) == pytest.approx(centroid, abs=1e-15)
    assert floats(body.get("quat")).tolist() == [1.0, 0.0, 0.0, 0.0]
    points = np.array([[0, 0, 2], [1, 0, 2], [0, 2, 2]]) - centroid
    m = np.array([1.0 + 1.0 + 0.3, 1.0, 1.0])
    com = m @ points / m.sum()
    r = points - com
    I = sum(mk * (rk @ rk * np.eye(3) - np.outer(rk, rk)) for mk, rk in zip(m, r))
    I = I + INERTIA_MARGIN * np.trace(I) * np.eye(3)
    inertial = body.find("inertial")
    assert float(inertial.get("mass")) == pytest.approx(m.sum(), rel=1e-15)
    assert floats(inertial.get("pos")) == pytest.approx(com, abs=1e-15)
    assert floats(inertial.get("fullinertia")) == pytest.approx(
        [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]], rel=1e-14, abs=1e-15)
    sites = body.findall("site")
    assert [x.get("name") for x in sites] == ["node:b1", "node:b2", "node:b3"]
    assert np.array([floats(x.get("pos")) for x in sites]) == pytest.approx(points, abs=1e-15)
    # members: stiffness EA/l0, the dead band of strings, damping on every tendon
    tendons = {t.get("name"): t for t in root.find("tendon")}
    for name in s.member_names:
        i = s.member_index(name)
        t = tendons[f"member:{name}"]
        assert [x.get("site") for x in t.findall("site")] == [f"node:{s.node_names[k]}" for k in s.members[i]]
        assert float(t.get("damping")) == 0.7
        l0 = s.rest_lengths[i]
        if s.member_kinds[i] == "string":
            assert floats(t.get("springlength")).tolist() == [0.0, l0]
        elif s.member_kinds[i] == "bar":
            assert floats(t.get("springlength")).tolist() == [l0]
        if s.member_kinds[i] != "actuator":
            assert float(t.get("stiffness")) == pytest.approx(s.EA[i] / l0, rel=1e-15)
        else:
            assert t.get("stiffness") is None
    # the actuator member: force gain * ctrl + bias = -EA (l - l0)/l0 at ctrl = 1 - l0_ref/l0
    actuators = {a.get("name"): a for a in root.find("actuator")}
    act = actuators["member:act_br"]
    i = s.member_index("act_br")
    EA, l0_ref, l0 = s.EA[i], s.rest_lengths[i], 2.0
    ctrl = 1.0 - l0_ref / l0
    for length in (1.5, 2.0, 2.7):
        g, b = floats(act.get("gainprm")), floats(act.get("biasprm"))
        force = (g[0] + g[1] * length) * ctrl + b[0] + b[1] * length
        assert force == pytest.approx(-EA * (length - l0) / l0, rel=1e-12, abs=1e-9)
    # dead loads: constant forces along F/|F| in the world frame; none on the pinned node
    assert set(actuators) == {"member:act_br", "load:f", "load:b3"}
    for name, force in (("f", [3.0, 0.0, 4.0]), ("b3", [0.0, -2.0, 0.0])):
        a = actuators[f"load:{name}"]
        assert (a.get("site"), a.get("refsite")) == (f"node:{name}", "world:origin")
        assert float(a.get("biasprm").split()[0]) * floats(a.get("gear"))[:3] == pytest.approx(force, rel=1e-15)
        assert floats(a.get("gainprm")).tolist() == [0.0]
    # the initial state: qpos0 and the keyframe
    key = root.find("keyframe/key")
    assert key.get("name") == "initial"
    assert floats(key.get("qpos")).tolist() == [0.0] * 5 + [*centroid.tolist(), 1.0, 0.0, 0.0, 0.0]
    assert floats(key.get("ctrl")) == pytest.approx([ctrl, 0.0, 0.0], rel=1e-15)


def test_names_are_escaped_and_read_back():
    s = Structure.from_arrays([[0, 0, 0], [1, 0, 0]], [[0, 1]], EA=10.0, pinned=[True, False], node_masses=[0, 1],
                              node_names=["a&b", 'c"<d>'], member_names=["m 1"])
    root = ET.fromstring(export_mjcf(s).xml)
    assert root.find("worldbody/body").get("name") == 'node:c"<d>'
    assert root.find("tendon/spatial").get("name") == "member:m 1"


def test_a_structure_exports_with_its_own_gravity_and_loads_from_the_drawing():
    s = small_structure().replace(gravity=np.array([0.0, -2.0, 0.0]))
    root = ET.fromstring(export_mjcf(s).xml)
    assert floats(root.find("option").get("gravity")).tolist() == [0.0, -2.0, 0.0]
    assert root.find("actuator/general[@name='load:f']") is None       # it has no loads
    assert floats(root.find("keyframe/key").get("qpos"))[:5].tolist() == [0.0] * 5
    assert root.find("tendon/spatial").get("damping") is None


def test_the_default_step_of_a_mass_on_a_spring():
    """One node of mass m on a bar of stiffness k: the fastest rate is sqrt(k/m) (the bar's
    axis; sideways the unstressed bar is not stiff), plus c/m with a damper."""
    m, k, c = 2.0, 800.0, 30.0
    s = Structure.from_arrays([[0, 0, 0], [1, 0, 0]], [[0, 1]], EA=k, kinds="bar", pinned=[True, False],
                              node_masses=[0, m])
    model = export_mjcf(s)
    assert model.fastest_rate == pytest.approx(math.sqrt(k / m), rel=1e-12)
    assert model.timestep == round_down_125(0.2 / math.sqrt(k / m)) == 0.01
    damped = scene_from_dict({"model": {"kind": "general", "structure": structure_to_dict(s)},
                              "initial": {"drawn": True}, "effects": ["inertia", "springs", {"damping": {"c": c}}],
                              "duration": 1.0})
    model = export_mjcf(damped)
    assert model.fastest_rate == pytest.approx(math.sqrt(k / m) + c / m, rel=1e-12)
    assert model.timestep == round_down_125(0.2 / (math.sqrt(k / m) + c / m)) == 0.005
    assert export_mjcf(s, timestep=0.0123, integrator="implicitfast").xml.count(
        'timestep="0.0123" integrator="implicitfast"') == 1


@given(st.floats(1e-9, 1e6))
def test_round_down_125(x):
    y = round_down_125(x)
    mantissa = y / 10 ** math.floor(math.log10(y))
    assert min(abs(mantissa - v) for v in (1.0, 2.0, 5.0)) < 1e-9
    assert x / 2.5 < y <= x * (1 + 1e-12)


def test_what_cannot_be_exported_says_why_in_one_line():
    with pytest.raises(ExportError, match="^scene 'paper_fold' simulates the class-2 mechanism; only general"):
        export_mjcf(load_scene("paper_fold"))
    with pytest.raises(ExportError, match="quasi-static .* add 'inertia'"):
        export_mjcf(small_scene(effects=["springs"]))
    with pytest.raises(ExportError, match="^timestep must be a positive number of seconds, got -0.1"):
        export_mjcf(small_scene(), timestep=-0.1)
    with pytest.raises(ExportError, match="^timestep must be a positive number of seconds, got nan"):
        export_mjcf(small_scene(), timestep=math.nan)
    with pytest.raises(ExportError, match="^integrator must be one of RK4, Euler, implicit, implicitfast, got 'RK5'"):
        export_mjcf(small_scene(), integrator="RK5")
    with pytest.raises(ExportError, match="^structure 'T-bar': inertia needs a mass on every free node; 'n2'"):
        export_mjcf(load_example("t_bar"))


def test_write_is_whole_or_nothing(tmp_path):
    model = export_mjcf(load_scene("table_gravity"))
    target = tmp_path / "table.xml"
    model.write(target)
    assert target.read_text(encoding="utf-8") == model.xml
    blocked = tmp_path / "blocked.xml"          # a folder: the rename into place fails
    blocked.mkdir()
    with pytest.raises(OSError):
        model.write(blocked)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocked.xml", "table.xml"]     # no partial file


@pytest.mark.parametrize("n", [50, DENSE_DOF + 200])
def test_the_largest_eigenvalue_dense_and_sparse(n):
    """A pencil (Q^T diag(k) Q, Q^T diag(m) Q) with Q a sparse orthogonal matrix (disjoint
    Givens rotations) has the eigenvalues k_i / m_i when the rotation pairs share m: the
    largest magnitude is known in closed form, for indefinite K too."""
    rng = np.random.default_rng(n)
    k = rng.uniform(-50.0, 100.0, n)
    m = np.repeat(rng.uniform(0.5, 2.0, n // 2), 2)
    k[n // 3] = 400.0 * m[n // 3]                     # the largest: 400
    Q = sp.lil_matrix((n, n))
    for i in range(0, n, 2):
        c, s = math.cos(i), math.sin(i)
        Q[i, i], Q[i, i + 1], Q[i + 1, i], Q[i + 1, i + 1] = c, s, -s, c
    Q = Q.tocsr()
    K = Q.T @ sp.diags(k) @ Q
    M = Q.T @ sp.diags(m) @ Q
    assert largest_eigenvalue_magnitude(K, M) == pytest.approx(400.0, rel=2e-3)
