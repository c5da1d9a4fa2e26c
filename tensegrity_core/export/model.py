"""The exported MJCF model: the document and what it holds."""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class MjcfModel:
    """An exported model: the MJCF document ``xml`` and what it holds.

    ``timestep`` [s] and ``integrator`` as written; ``fastest_rate`` [1/s] the bound on the
    linearised dynamics' eigenvalues that the default step comes from
    (:mod:`tensegrity_core.export.timestep`); the counts of node bodies (free nodes), rigid
    bodies, tendons (members), dead loads and actuator members; ``nq``, ``nv`` MuJoCo's
    numbers of position and velocity coordinates. A robot's model also counts its ``rods``
    (among the rigid bodies), ``motors`` (position actuators), floor ``contacts`` (pairs) and
    ``sensors``; its ``fastest_rate`` is nan (its step is the 1 kHz loop's)."""

    name: str
    xml: str
    timestep: float
    integrator: str
    fastest_rate: float
    node_bodies: int
    rigid_bodies: int
    tendons: int
    loads: int
    actuator_members: int
    nq: int
    nv: int
    rods: int = 0
    motors: int = 0
    contacts: int = 0
    sensors: int = 0

    def write(self, path: str | os.PathLike[str]) -> None:
        """Write the document to ``path`` (whole or not at all: a temporary file renamed into
        place); raises ``OSError``."""
        target = Path(path)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(self.xml)
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
