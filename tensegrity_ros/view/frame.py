"""What the view draws: a structure's fixed :class:`Topology` and one :class:`Frame` of its state.

A frame is the view's only input. A ROS subscription (:mod:`.ros_source`), a bag
(:mod:`.bag_source`) and the core simulator run in the view's process (:mod:`.scene_source`)
each fill frames the same way, so the drawing, the plots and the status line never know
where a frame came from.

Conventions: SI units (m, N, s); positions in the structure's world frame (Z up; the
class-2 mechanism lies in the XY plane, z = 0); member forces tension positive. Member
kinds are the core's (:data:`tensegrity_core.general.structure.MEMBER_KINDS`): ``"bar"``
(tension and compression, drawn as a cylinder), ``"string"`` (tension only: a cable or a
spring, drawn as a line coloured by its tension, thin when slack), ``"actuator"`` (a member
whose length or force is the input, drawn as a cylinder).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Final

import numpy as np
from numpy.typing import NDArray

MEMBER_KINDS: Final = ("bar", "string", "actuator")
#: Run states a frame reports: the simulator's (``simulation_interfaces``: playing, paused,
#: stopped, quitting, no world, loading world), ``"lockstep"`` for a playing lockstep
#: simulator, ``"recorded"`` for a bag, ``"unknown"`` before the simulator has answered,
#: ``"no simulator"`` once a running suite's simulator has left the graph.
RUN_STATES: Final = ("playing", "paused", "stopped", "quitting", "no world", "loading world", "lockstep", "recorded",
                     "unknown", "no simulator")


@dataclass(frozen=True, eq=False)
class Topology:
    """What does not change while a structure moves.

    ``kind``: ``"class2"``, ``"general"`` or ``"robot"`` (rods, cables, a floor);
    ``members`` (m, 2) node indices; ``member_kinds`` one of :data:`MEMBER_KINDS` per member;
    ``bodies`` rigid bodies as ``(name, node indices)``; ``end_effector`` the index of the
    node whose path is drawn (class-2: node D), or None; ``floor``: draw the plane z = 0;
    ``bar_radius`` and ``node_radius`` [m]: a robot's rod and end-cap radii, drawn to scale
    (0: sizes that scale with the structure's extent); ``series_groups``: the plotted quantities as ``(title with unit, names)``, e.g.
    ``("actuator forces [N]", ("f1", "f2"))``, each name a key of every frame's ``series``.
    """

    kind: str
    node_names: tuple[str, ...]
    member_names: tuple[str, ...]
    members: NDArray[np.int64]
    member_kinds: tuple[str, ...]
    bodies: tuple[tuple[str, tuple[int, ...]], ...] = ()
    end_effector: int | None = None
    floor: bool = False
    bar_radius: float = 0.0
    node_radius: float = 0.0
    series_groups: tuple[tuple[str, tuple[str, ...]], ...] = ()

    def __post_init__(self) -> None:
        n, m = len(self.node_names), len(self.member_names)
        members = np.asarray(self.members, dtype=np.int64).reshape(-1, 2)
        if len(members) != m or len(self.member_kinds) != m:
            raise ValueError(f"{m} member names, {len(members)} node pairs and {len(self.member_kinds)} kinds")
        if m and (members.min() < 0 or members.max() >= n):
            raise ValueError(f"a member names a node outside 0..{n - 1}")
        unknown = set(self.member_kinds) - set(MEMBER_KINDS)
        if unknown:
            raise ValueError(f"unknown member kinds {sorted(unknown)} (known: {', '.join(MEMBER_KINDS)})")
        object.__setattr__(self, "members", members)

    def of_kind(self, *kinds: str) -> NDArray[np.int64]:
        """Indices of the members of the given kinds, in member order."""
        return np.array([i for i, k in enumerate(self.member_kinds) if k in kinds], dtype=np.int64)


@dataclass(frozen=True, eq=False)
class Frame:
    """The state of a structure at simulation time ``t`` [s].

    ``nodes`` (n, 3) [m]; ``member_forces`` (m,) [N], tension positive; ``contacts`` as
    ``(point (3,) [m], normal force [N] >= 0)`` (a class-2 fold limit: the folded actuator's
    middle; a robot: the centre of an end cap touching the floor); ``series``: the plotted scalars by name (the names
    and units of the topology's ``series_groups``); ``run_state`` one of :data:`RUN_STATES`.
    """

    t: float
    nodes: NDArray[np.float64]
    member_forces: NDArray[np.float64]
    run_state: str = "unknown"
    contacts: tuple[tuple[NDArray[np.float64], float], ...] = ()
    series: dict[str, float] = field(default_factory=dict)
