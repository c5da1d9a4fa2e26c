"""What an observation of the class-2 mechanism reports, for one sample or for a whole run.

:class:`Class2Observer` turns states into the observed quantities: node positions, member
lengths and forces (:mod:`.members`), end effector (node D), energies, contact
forces and, with inertia, the accelerations of each sample's contact mode (the kernel's
:class:`~tensegrity_core.class2.dynamics.inertia.Inertia`).
:meth:`Class2Observer.many` takes arrays over the samples of a run;
:meth:`Class2Observer.one` takes one sample and evaluates the same formulas on floats (the
effects, the inertia and the member forces are written with arithmetic only), which costs a
few tens of microseconds instead of a few hundred: the ROS node observes at up to 1 kHz.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.dynamics.effects import force_terms
from tensegrity_core.class2.dynamics.inertia import Inertia
from tensegrity_core.class2.dynamics.kinematics import Kinematics, kinematics, kinematics_array
from tensegrity_core.class2.dynamics.limits import LAMBDA_MIN_REL
from tensegrity_core.class2.geometry import NODE_NAMES
from tensegrity_core.sim.class2.members import member_values, node_coordinates
from tensegrity_core.sim.class2.setup import ForceEffect, class2_params
from tensegrity_core.sim.model import Observed, ObservedArrays
from tensegrity_core.sim.scene import Scene

END_EFFECTOR = NODE_NAMES.index("D")


class _MemberOptions(TypedDict):
    """The scene's options of :func:`~tensegrity_core.sim.class2.members.member_values`."""

    springs: bool
    damping: bool
    gravity: tuple[float, ...] | None
    loads: NDArray[np.float64] | None
    inertia: bool


class Class2Observer:
    """Observed quantities of a class-2 scene with force ``effects`` (the model's, in
    composition order); ``inertia`` False for the quasi-static model (massless struts: no
    accelerations, kinetic energy 0, contact forces given by the caller)."""

    def __init__(self, scene: Scene, effects: Iterable[ForceEffect], *, inertia: bool):
        self.params = class2_params(scene)
        self.L = self.params.L
        self.effects = tuple(effects)
        self._energies = tuple(e.energy for e in self.effects if hasattr(e, "energy"))
        self._forces = force_terms(self.effects)
        self.inertia = Inertia(self.params) if inertia else None
        eff = scene.effects
        self.gravity = tuple(eff["gravity"].vector) if "gravity" in eff else None
        self.loads: NDArray[np.float64] | None = None
        if "loads" in eff:
            self.loads = np.zeros((6, 2))
            for node, vec in eff["loads"].forces.items():
                self.loads[node] += vec[:2]
        self._members = _MemberOptions(springs="springs" in eff, damping="damping" in eff, gravity=self.gravity,
                                       loads=self.loads, inertia=inertia)

    def one(self, t: float, y: ArrayLike, bits: int, T: Sequence[float] | NDArray[np.float64],
            contact: Sequence[float] | None = None) -> Observed:
        """The observation of one state ``y`` (q, qdot, ...) at ``t`` in contact mode ``bits``
        with transmitted actuator forces ``T`` (2,); ``contact`` (2,) the contact forces when
        known (quasi-static). Values as :meth:`many` gives them, without the sample axis."""
        y = np.asarray(y, dtype=float)
        yl = y.tolist()
        k = kinematics(self.L, yl, LAMBDA_MIN_REL * self.L)
        T1, T2 = float(T[0]), float(T[1])
        potential = 0.0
        for energy in self._energies:
            potential += energy(k)
        if self.inertia is not None:
            Q1 = Q2 = Q3 = 0.0
            for force in self._forces:
                a, b, c = force(k)
                Q1, Q2, Q3 = Q1 + a, Q2 + b, Q3 + c
            a1, a2, a3, l1, l2 = self.inertia.solve(k, Q1 - T1, Q2 - T2, Q3, int(bits))
            kinetic = self.inertia.kinetic_energy(k)
        else:
            a1 = a2 = a3 = 0.0
            l1, l2 = (0.0, 0.0) if contact is None else (float(contact[0]), float(contact[1]))
            kinetic = 0.0
        forces, lengths = member_values(self.params, k, (a1, a2, a3), (T1 - l1, T2 - l2), **self._members)
        Bx, Cx, Dx, Dy, Ex, Ey, Fy = node_coordinates(self.L, k)
        nodes = np.array([[0.0, 0.0, 0.0], [Bx, 0.0, 0.0], [Cx, 0.0, 0.0], [Dx, Dy, 0.0], [Ex, Ey, 0.0],
                          [0.0, Fy, 0.0]])
        return Observed(
            t=float(t), state=y.copy(), q=np.array(yl[:3]), qdot=np.array(yl[3:6]), qddot=np.array([a1, a2, a3]),
            applied_forces=np.array([T1, T2]), contact_forces=np.array([l1, l2]), nodes=nodes,
            member_lengths=np.array(lengths), member_forces=np.array(forces), end_effector=nodes[END_EFFECTOR].copy(),
            potential_energy=float(potential), kinetic_energy=float(kinetic), folded=bits != 0,
        )

    def many(self, t: ArrayLike, Y: ArrayLike, bits: ArrayLike, T: ArrayLike,
             contact: ArrayLike | None = None) -> ObservedArrays:
        """Observed quantities of N samples: times ``t`` (N,), states ``Y`` (N, n), contact
        modes ``bits`` (N,), transmitted actuator forces ``T`` (N, 2), and ``contact`` (N, 2)
        the contact forces when known (quasi-static; otherwise they come with the
        accelerations of each sample's mode)."""
        t = np.asarray(t, dtype=float)
        Y = np.asarray(Y, dtype=float).reshape(len(t), -1)
        bits = np.asarray(bits, dtype=int)
        T = np.asarray(T, dtype=float).reshape(len(t), 2)
        n = len(t)
        q, qd = Y[:, :3], Y[:, 3:6]
        k = kinematics_array(self.L, q, qd)
        potential = np.zeros(n)
        for energy in self._energies:
            potential = potential + energy(k)
        qdd = np.zeros((n, 3))
        lam = np.zeros((n, 2)) if contact is None else np.asarray(contact, dtype=float)
        kinetic = np.zeros(n)
        if self.inertia is not None:
            Q = np.zeros((3, n))
            for force in self._forces:
                Q += np.array(np.broadcast_arrays(*force(k)))
            Q[:2] -= T.T
            for mode in np.unique(bits):
                sel = bits == mode
                ks = Kinematics(*(np.asarray(v)[sel] for v in k))
                a1, a2, a3, l1, l2 = self.inertia.solve(ks, Q[0, sel], Q[1, sel], Q[2, sel], int(mode))
                qdd[sel] = np.stack(np.broadcast_arrays(a1, a2, a3), -1)
                lam[sel] = np.stack(np.broadcast_arrays(l1, l2), -1)
            kinetic = self.inertia.kinetic_energy(k)
        acting = T - lam
        forces, lengths = member_values(self.params, k, (qdd[:, 0], qdd[:, 1], qdd[:, 2]),
                                        (acting[:, 0], acting[:, 1]), **self._members)
        member_forces, member_lengths = np.empty((n, 10)), np.empty((n, 10))
        for j in range(10):
            member_forces[:, j], member_lengths[:, j] = forces[j], lengths[j]
        nodes = np.zeros((n, 6, 3))
        Bx, Cx, Dx, Dy, Ex, Ey, Fy = node_coordinates(self.L, k)
        nodes[:, 1, 0], nodes[:, 2, 0], nodes[:, 3, 0], nodes[:, 3, 1] = Bx, Cx, Dx, Dy
        nodes[:, 4, 0], nodes[:, 4, 1], nodes[:, 5, 1] = Ex, Ey, Fy
        return ObservedArrays(
            t=t, state=Y, q=q.copy(), qdot=qd.copy(), qddot=qdd, applied_forces=T, contact_forces=lam, nodes=nodes,
            member_lengths=member_lengths, member_forces=member_forces, end_effector=nodes[:, END_EFFECTOR].copy(),
            potential_energy=potential, kinetic_energy=kinetic, folded=bits != 0,
        )
