"""A simulated run at the output rate: arrays over time, events, and NPZ / CSV files.

Arrays (``N`` output samples): ``times`` (N,) [s]; ``states`` (N, n) the model's state
vector (names in ``state_names``); ``q``, ``qdot``; ``applied_forces`` (N, a);
``member_forces``, ``member_lengths`` (N, m); ``nodes`` (N, n_nodes, 3); ``end_effector``
(N, 3); ``potential_energy``, ``kinetic_energy`` (N,); ``folded`` (N,) bool;
``contact_forces``. ``events`` lists ``(t, kind, index)``. With sensor noise,
``measurements`` holds the noisy copies of the listed quantities. Robots add ``readings``
(:data:`READINGS`: the centre of mass, and with the ``sensors`` effect the sensors' readings
and the caps' contact state). ``success`` is False when
the run stopped early (``message`` says why; the arrays end at the last good sample);
``violations`` lists the invariants the run broke, one line each
(:mod:`tensegrity_core.sim.invariants`; empty for a sound run).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.events import LoggedEvent, as_event_kind, event_subject
from tensegrity_core.sim.model import Stats

if TYPE_CHECKING:
    from tensegrity_core.sim.model import Names, ObservedArrays
    from tensegrity_core.sim.scene import Scene

FloatArray = NDArray[np.float64]

ARRAYS = ("times", "states", "q", "qdot", "applied_forces", "contact_forces", "member_forces",
          "member_lengths", "nodes", "end_effector", "potential_energy", "kinetic_energy", "folded")

#: A robot's readings a trajectory keeps (``readings``), with their units and shapes over the
#: ``N`` samples; columns in the robot file's order: the sensed cables (``sensors.cable_length``
#: and ``sensors.cable_tension``), the IMUs (``sensors.imu``), the caps (each rod's two end
#: caps, in rod order).
READINGS: dict[str, str] = {
    "centre_of_mass": "[m] (N, 3), world frame",
    "cable_lengths": "[m] (N, sensed cables)",
    "cable_tensions": "[N] (N, sensed cables), tension positive",
    "imu_orientation": "unit quaternion x, y, z, w (N, IMUs, 4), the rod's frame in the world",
    "imu_angular_velocity": "[rad/s] (N, IMUs, 3), in the rod's frame",
    "imu_specific_force": "[m/s^2] (N, IMUs, 3), in the rod's frame (at rest: -gravity)",
    "cap_contact": "bool (N, caps), the cap touches the floor",
    "cap_slipping": "bool (N, caps), the cap slides on the floor",
    "friction_forces": "[N] (N, caps, 3), world frame, on the cap",
}


@dataclass
class Trajectory:
    scene_name: str
    times: FloatArray
    states: FloatArray
    q: FloatArray
    qdot: FloatArray
    applied_forces: FloatArray
    contact_forces: FloatArray
    member_forces: FloatArray
    member_lengths: FloatArray
    nodes: FloatArray
    end_effector: FloatArray
    potential_energy: FloatArray
    kinetic_energy: FloatArray
    folded: NDArray[np.bool_]
    node_names: tuple[str, ...] = ()
    member_names: tuple[str, ...] = ()
    member_nodes: NDArray[np.int_] = field(default_factory=lambda: np.zeros((0, 2), dtype=int))
    state_names: tuple[str, ...] = ()
    actuator_names: tuple[str, ...] = ()
    events: list[LoggedEvent] = field(default_factory=list)
    measurements: dict[str, FloatArray] = field(default_factory=dict)
    readings: dict[str, NDArray[Any]] = field(default_factory=dict)
    stats: Stats = field(default_factory=Stats)
    success: bool = True
    message: str = ""
    scene: dict[str, Any] = field(default_factory=dict, repr=False)
    violations: list[str] = field(default_factory=list)

    @classmethod
    def from_observations(cls, scene: Scene, data: ObservedArrays, names: Names,
                          events: Iterable[LoggedEvent], measurements: dict[str, FloatArray], stats: Stats, *,
                          error: str = "", state_names: Iterable[str] = (),
                          violations: Iterable[str] = ()) -> Trajectory:
        """The trajectory of a run: ``data`` the model's observations (arrays over the samples),
        ``names`` its :class:`~tensegrity_core.sim.model.Names`."""
        return cls(
            scene_name=scene.name, times=data["t"], states=data["state"], q=data["q"], qdot=data["qdot"],
            applied_forces=data["applied_forces"], contact_forces=data["contact_forces"],
            member_forces=data["member_forces"], member_lengths=data["member_lengths"], nodes=data["nodes"],
            end_effector=data["end_effector"], potential_energy=data["potential_energy"],
            kinetic_energy=data["kinetic_energy"], folded=data["folded"], node_names=tuple(names.node_names),
            member_names=tuple(names.member_names), member_nodes=np.asarray(names.member_nodes),
            state_names=tuple(state_names), actuator_names=tuple(scene.inputs), events=list(events),
            measurements=measurements, readings={k: np.asarray(v) for k, v in data.items() if k in READINGS},
            stats=stats, success=not error,
            message=error or f"simulated {scene.duration:g} s", scene=scene.data, violations=list(violations))

    def __len__(self) -> int:
        return len(self.times)

    # -- files -------------------------------------------------------------------------------
    def to_npz(self, path: str | Path) -> Path:
        """Write every array, the names, events, statistics and the scene to ``path`` (.npz);
        ``measurements`` as ``measured_<name>``, ``readings`` as ``reading_<name>``."""
        path = Path(path)
        # (values Any: numpy's stub types the arrays passed as **kwds like its allow_pickle flag)
        arrays: dict[str, Any] = {k: np.asarray(getattr(self, k)) for k in ARRAYS}
        arrays["member_nodes"] = np.asarray(self.member_nodes)
        for k, v in self.measurements.items():
            arrays[f"measured_{k}"] = np.asarray(v)
        for k, v in self.readings.items():
            arrays[f"reading_{k}"] = np.asarray(v)
        meta = {"scene_name": self.scene_name, "node_names": list(self.node_names),
                "member_names": list(self.member_names), "state_names": list(self.state_names),
                "actuator_names": list(self.actuator_names),
                "events": [[float(t), str(kind), int(i)] for t, kind, i in self.events],
                "stats": self.stats, "success": self.success, "message": self.message, "scene": self.scene,
                "violations": list(self.violations)}
        arrays["meta"] = np.array(json.dumps(meta, default=float))
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        return path

    @classmethod
    def from_npz(cls, path: str | Path) -> Trajectory:
        with np.load(Path(path), allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in ARRAYS}
            measured = {k[len("measured_"):]: z[k] for k in z.files if k.startswith("measured_")}
            readings = {k[len("reading_"):]: z[k] for k in z.files if k.startswith("reading_")}
            member_nodes = z["member_nodes"]
        return cls(scene_name=meta["scene_name"], **arrays, node_names=tuple(meta["node_names"]),
                   member_names=tuple(meta["member_names"]), member_nodes=member_nodes,
                   state_names=tuple(meta["state_names"]), actuator_names=tuple(meta["actuator_names"]),
                   events=[(float(t), as_event_kind(str(kind)), int(i)) for t, kind, i in meta["events"]],
                   measurements=measured, readings=readings,
                   stats=meta["stats"], success=meta["success"], message=meta["message"], scene=meta["scene"],
                   violations=list(meta.get("violations", [])))

    def csv_columns(self) -> tuple[list[str], FloatArray]:
        """Column names and the (N, k) table written by :meth:`to_csv`."""
        cols = ["t"] + list(self.state_names or [f"y{i + 1}" for i in range(self.states.shape[1])])
        parts = [self.times[:, None], self.states]
        cols += [f"applied_{a}" for a in self.actuator_names] or \
            [f"applied_{i + 1}" for i in range(self.applied_forces.shape[1])]
        parts.append(self.applied_forces)
        cols += ["end_effector_x", "end_effector_y", "end_effector_z"]
        parts.append(self.end_effector)
        cols += [f"force_{m}" for m in self.member_names]
        parts.append(self.member_forces)
        cols += ["potential_energy", "kinetic_energy", "folded"]
        parts += [self.potential_energy[:, None], self.kinetic_energy[:, None], self.folded[:, None].astype(float)]
        return cols, np.hstack([np.asarray(p, dtype=float).reshape(len(self.times), -1) for p in parts])

    def to_csv(self, path: str | Path) -> Path:
        """One row per output sample; comment lines (``#``) carry the scene name and the events."""
        path = Path(path)
        cols, table = self.csv_columns()
        header = [f"scene: {self.scene_name}", f"status: {'ok' if self.success else 'stopped'}: {self.message}"]
        header += [f"event: t={t:.12g} {kind} {event_subject(kind, i)}".rstrip() for t, kind, i in self.events]
        header += [f"violation: {v}" for v in self.violations]
        with open(path, "w", encoding="utf-8") as fh:
            for line in header:
                fh.write(f"# {line}\n")
            fh.write(",".join(cols) + "\n")
            np.savetxt(fh, table, delimiter=",", fmt="%.17g")
        return path
