"""The constant arrays the kernels read: a general model compiled once into index and value arrays.

A :class:`Plan` is the model's topology and constants (MuJoCo's ``mjModel``): which node
each free coordinate moves, which nodes ride on which rigid body and where, the members'
end nodes, stiffness, damping and kind, the lumped masses and the bodies' inertia, the
constant external forces. Everything a right-hand side, a Jacobian or an observation needs
that does not change while integrating; what does change -- the state ``y``, the bodies'
rotation charts ``R_ref`` and the rest lengths at ``t`` -- is passed to each call.

Conventions: lengths [m], forces [N] (member force positive = tensile), masses [kg],
inertia [kg m^2] about the body's reference point ``c`` (the centroid of its nodes) in the
body's reference frame (the drawing's axes).

The arrays are of one kind (:func:`frozen`): C-ordered, read-only, float64, int64 or bool.
numba compiles a kernel once per kind of its arguments -- dtype, dimensions, memory layout
and whether they are writable -- so a plan whose member ends were a column of a read-only
table, or a copy of it, would each compile the kernels again (seconds to minutes) where the
set-up's warm-up (:mod:`.warm`) compiled them once for every model.
"""

from __future__ import annotations

from typing import NamedTuple, TypeVar

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.dofs import DofLayout
from tensegrity_core.general.rotation import hat
from tensegrity_core.general.structure import Structure

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
P = TypeVar("P", bound=tuple[np.ndarray, ...])

#: The dtypes of the kernels' arrays.
KINDS = (np.dtype(np.float64), np.dtype(np.int64), np.dtype(np.bool_))


def constant(a: np.ndarray) -> np.ndarray:
    """``a`` as the kernels' one kind of constant array: C-ordered and read-only (a copy,
    unless it is one already; the caller's array stays writable)."""
    assert a.dtype in KINDS, f"a kernel array of dtype {a.dtype}"
    if a.flags.c_contiguous and not a.flags.writeable:
        return a
    out = np.array(a, order="C")
    out.setflags(write=False)
    return out


def frozen(plan: P) -> P:
    """``plan`` (a :class:`Plan`, a :class:`Placement` or a robot's plan: a named tuple of
    arrays) with every array :func:`constant`: the kind the kernels are compiled for."""
    return type(plan)(*(constant(a) for a in plan))


class Placement(NamedTuple):
    """The arrays that place a model's nodes and accelerate its coordinates: the first twelve
    of every kernels' plan (:class:`Plan`; the robots' ``RobotPlan`` builds on them), so that
    the kernels that place nodes and apply Newton-Euler serve both. Fields as in :class:`Plan`."""

    base: FloatArray
    free_node: IntArray
    free_axis: IntArray
    free_inv_mass: FloatArray
    on_node: IntArray
    on_body: IntArray
    on_offset: FloatArray
    body_dof: IntArray
    body_mass: FloatArray
    body_first_moment: FloatArray
    body_inertia: FloatArray
    body_inv_inertia_cm: FloatArray


def build_placement(layout: DofLayout, nodes: FloatArray, *, free_masses: FloatArray, body_masses: FloatArray,
                    body_first_moments: FloatArray, body_inertia: FloatArray) -> Placement:
    """The placement of a model of coordinates ``layout`` and drawn ``nodes`` (n, 3) [m] with
    its lumped masses: per free coordinate (in ``layout``'s order) [kg], per moving body its
    mass [kg], first moment [kg m] and inertia about ``c`` in the body frame [kg m^2]."""
    free_node, free_axis = np.nonzero(layout.free_index >= 0)
    order = np.argsort(layout.free_index[free_node, free_axis])
    on = np.flatnonzero(layout.node_body >= 0)
    mass = np.asarray(body_masses, dtype=float)
    first = np.asarray(body_first_moments, dtype=float).reshape(-1, 3)
    inertia = np.asarray(body_inertia, dtype=float).reshape(-1, 3, 3)
    # inertia about the centre of mass d = s/m: I_cm = I_c + hat(s) hat(s) / m (parallel axes)
    S = hat(first)
    inertia_cm = inertia + S @ S / mass[:, None, None] if len(mass) else inertia
    return frozen(Placement(
        base=np.array(nodes, dtype=float),
        free_node=free_node[order].astype(np.int64),
        free_axis=free_axis[order].astype(np.int64),
        free_inv_mass=1.0 / np.asarray(free_masses, dtype=float),
        on_node=on.astype(np.int64),
        on_body=layout.node_body[on].astype(np.int64),
        on_offset=np.array(layout.offsets[on], dtype=float).reshape(-1, 3),
        body_dof=np.asarray(layout.body_dof, dtype=np.int64),
        body_mass=mass,
        body_first_moment=first,
        body_inertia=inertia,
        body_inv_inertia_cm=np.linalg.inv(inertia_cm) if len(mass) else inertia.copy(),
    ))


class Plan(NamedTuple):
    """A general model's constant arrays (see the module docstring).

    Nodes (n): ``base`` (n, 3) drawn coordinates (fixed coordinates keep them).
    Free coordinates (n_free): ``free_node``, ``free_axis`` the node and axis each one moves,
    ``free_inv_mass`` (n_free,) 1 / lumped mass [1/kg].
    Body nodes (n_on): ``on_node`` the node, ``on_body`` its moving-body slot, ``on_offset``
    (n_on, 3) its offset ``p`` from the body's reference point in the body frame [m].
    Moving bodies (nb): ``body_dof`` the index in ``x`` of the centre (rotation vector at
    +3), ``body_mass`` [kg], ``body_first_moment`` (nb, 3) ``sum m_k p_k`` [kg m],
    ``body_inertia`` (nb, 3, 3) about ``c`` and ``body_inv_inertia_cm`` (nb, 3, 3) the
    inverse of the inertia about the centre of mass, both in the body frame.
    Members (m): ``member_a``, ``member_b`` end nodes (``h = x_b - x_a``), ``EA`` [N],
    ``damping`` [N s/m] (zero without dampers), ``is_string`` (slack below the rest length).
    ``external`` (n, 3) constant nodal forces: dead loads and weights [N].
    """

    base: FloatArray
    free_node: IntArray
    free_axis: IntArray
    free_inv_mass: FloatArray
    on_node: IntArray
    on_body: IntArray
    on_offset: FloatArray
    body_dof: IntArray
    body_mass: FloatArray
    body_first_moment: FloatArray
    body_inertia: FloatArray
    body_inv_inertia_cm: FloatArray
    member_a: IntArray
    member_b: IntArray
    EA: FloatArray
    damping: FloatArray
    is_string: NDArray[np.bool_]
    external: FloatArray

    @property
    def n_nodes(self) -> int:
        return len(self.base)

    @property
    def n_dof(self) -> int:
        """Length of ``x`` (and of ``v``): free coordinates plus six per moving body."""
        return len(self.free_node) + 6 * len(self.body_dof)


def build_plan(structure: Structure, *, free_masses: FloatArray, body_masses: FloatArray,
               body_first_moments: FloatArray, body_inertia: FloatArray, damping: FloatArray | None, external: FloatArray | None) -> Plan:
    """The plan of ``structure`` with its lumped masses (per free coordinate, per moving body
    with its first moment and inertia about ``c`` in the body frame), the
    members' damping coefficients (or None) and the constant external nodal forces (or None)."""
    placement = build_placement(structure.layout, structure.nodes, free_masses=free_masses, body_masses=body_masses,
                                body_first_moments=body_first_moments, body_inertia=body_inertia)
    m = structure.n_members
    return frozen(Plan(
        *placement,
        member_a=np.asarray(structure.members[:, 0], dtype=np.int64),
        member_b=np.asarray(structure.members[:, 1], dtype=np.int64),
        EA=np.array(structure.EA, dtype=float),
        damping=np.zeros(m) if damping is None else np.array(damping, dtype=float),
        is_string=np.array(structure.is_string, dtype=bool),
        external=np.zeros((structure.n_nodes, 3)) if external is None else np.array(external, dtype=float),
    ))
