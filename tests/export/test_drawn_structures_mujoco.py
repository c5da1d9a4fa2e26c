"""Drawn general structures in MuJoCo: over the masses and stiffnesses a structure accepts
(any positive number up to 1e15), the export writes a model MuJoCo loads with the
structure's lumped masses and forces, or refuses in one line what MuJoCo cannot take.

The structures are ``tests/hard/strategies.py``'s (4-8 nodes, bars and strings, dead loads,
perhaps a free rigid triangle), with point masses on every node and a member stiffness scale
drawn log-uniformly: node masses from 1e-20 to 1e15 kg, EA from 1e-15 to 1e15 N. MuJoCo is the
independent side (its compiler, its mass matrix, its tendon law with the dead band).

- **Loads or refuses.** A refusal is one line naming a free node whose lumped mass is below
  MuJoCo's ``mjMINVAL`` (1e-15 kg), or a rigid body whose mass is below it or whose inertia
  has an eigenvalue below ``mjEPS`` (1e-14 kg m^2), each checked here from the structure's
  own lumped masses; or a fastest rate that is not finite in double precision (then the
  user gives the step).
- **Masses and forces.** Each free node's MuJoCo body mass is its lumped mass, each rigid
  body's mass the sum of its nodes'; at the drawn state at rest MuJoCo's smooth generalised
  forces (``qfrc_smooth``) equal the members' ``EA (l - l0) / l0`` (strings only while
  taut), the weights and the dead loads summed on each free coordinate and body, to the
  rounding of the lengths (``64 eps`` of the drawing's size, times ``EA / l0``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.export import ExportError, export_mjcf
from tensegrity_core.export.mujoco_limits import MJEPS, MJMINVAL
from tensegrity_core.general.mass_properties import body_inertias
from tensegrity_core.sim.general.model import NodalMasses
from tests.hard.strategies import structures
from tests.mujoco_peer import body_force_expectation

EPS = np.finfo(float).eps


@pytest.fixture(autouse=True, scope="module")
def warnings_kept():
    """MuJoCo's warnings (an inertia too close to singular to factorise at extreme mass
    ratios) into a list rather than its log file in the working folder."""
    import mujoco

    kept: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(kept.append)
    yield kept
    mujoco.set_mju_user_warning(previous)


@settings(max_examples=60, deadline=None)
@given(structure=structures(), masses=st.lists(st.floats(-20.0, 15.0), min_size=8, max_size=8),
       stiffness=st.floats(-15.0, 9.0), gravity=st.booleans())
def test_a_drawn_structure_exports_with_its_masses_and_forces_or_says_why_not(structure, masses, stiffness,
                                                                              gravity):
    import mujoco

    n = structure.n_nodes
    s = structure.replace(node_masses=10.0 ** np.array(masses[:n]), EA=structure.EA * 10.0 ** stiffness,
                          gravity=np.array([0.0, 0.0, -9.81]) if gravity else np.zeros(3))
    lay = s.layout
    lumped = NodalMasses(s).node
    free = np.flatnonzero(~lay.fixed_mask.all(axis=1) & (lay.node_body < 0))
    bodies = body_inertias(s, lumped)
    light = [f"node {s.node_names[i]!r}" for i in free if lumped[i] < MJMINVAL]
    light += [f"rigid body {lay.body_names[k]!r}" for k, b in enumerate(bodies)
              if b.mass < MJMINVAL or np.linalg.eigvalsh(b.inertia)[0] < MJEPS * (1 + 1e-6)]
    try:
        exported = export_mjcf(s)
    except ExportError as err:
        text = str(err)
        assert "\n" not in text
        assert any(what in text for what in light) or "no time step follows" in text, text
        return
    assert not [w for w in light if w.startswith("node")]
    m = mujoco.MjModel.from_xml_string(exported.xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    mujoco.mj_forward(m, d)
    X = s.nodes
    size = float(np.abs(X).max()) + float(np.ptp(X, axis=0).max())
    # the members' pulls, the weights and the dead loads at the nodes [N]
    a, b = s.members[:, 0], s.members[:, 1]
    u = X[b] - X[a]
    length = np.linalg.norm(u, axis=1)
    k = s.EA / s.rest_lengths
    force = k * (length - s.rest_lengths)
    force = np.where((np.asarray(s.member_kinds) == "string") & (force < 0), 0.0, force)
    pull = force[:, None] * u / length[:, None]
    nodal = s.loads + lumped[:, None] * s.gravity
    np.add.at(nodal, a, pull)
    np.add.at(nodal, b, -pull)
    err = 1e-12 * np.abs(force) + k * 64 * EPS * (size + length)
    rounding = 1e-12 * (np.abs(s.loads) + np.abs(lumped[:, None] * s.gravity)).sum(axis=1)
    np.add.at(rounding, a, err)
    np.add.at(rounding, b, err)
    expected, tolerance = np.zeros(m.nv), np.zeros(m.nv)
    for i in free:
        body = m.body(f"node:{s.node_names[i]}").id
        assert m.body_mass[body] == pytest.approx(lumped[i], rel=1e-12)
        for axis in np.flatnonzero(~lay.fixed_mask[i]):
            v = m.jnt_dofadr[m.joint(f"node:{s.node_names[i]}:{'xyz'[axis]}").id]
            expected[v], tolerance[v] = nodal[i, axis], rounding[i]
    for slot, idx in enumerate(lay.body_nodes):
        body = m.body(f"body:{lay.body_names[slot]}").id
        assert m.body_mass[body] == pytest.approx(lumped[idx].sum(), rel=1e-12)
        v, force, allowance = body_force_expectation(m, d, body, nodal[idx], rounding[idx], X[idx], size)
        expected[v:v + 6], tolerance[v:v + 6] = force, allowance
    assert np.all(np.abs(d.qfrc_smooth - expected) <= tolerance), (d.qfrc_smooth, expected, tolerance)
