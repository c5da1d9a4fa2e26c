"""Form-finding as a separate process for the ``find_form`` service (no ROS in here).

Each request runs in a process forked from a forkserver that has the numerical core
preloaded, so a long request neither holds the node's interpreter lock nor delays other
callers, and a request over its time limit is stopped without touching the others.
"""

from __future__ import annotations

import math
import time
import traceback
from dataclasses import dataclass, field

from tensegrity_core.errors import TensegrityError


@dataclass
class FormFindReply:
    """What one form-finding request answers (plain values, picklable across the worker's
    pipe): ``nodes`` [[x, y, z], ...] [m] in the description's order, ``member_forces`` [N]
    tension positive, ``residual`` the largest out-of-balance force/moment [N, N m]."""

    success: bool = False
    message: str = ""
    nodes: list = field(default_factory=list)
    member_forces: list = field(default_factory=list)
    iterations: int = 0
    residual: float = math.nan
    min_stiffness_eigenvalue: float = math.nan


def solve(text: str, tol: float, max_iter: int, time_limit: float, max_members: int) -> FormFindReply:
    """Parse a structure description and form-find it; always returns a reply (failures
    too). ``tol`` <= 0 and ``max_iter`` == 0 mean the core's defaults.
    """
    from tensegrity_core.general import form_find, load_structure

    try:
        structure = load_structure(text)
        n_members = len(structure.member_names)
        if n_members > max_members:
            return FormFindReply(message=f"structure has {n_members} members, more than this service's "
                                         f"limit max_members = {max_members}")
        start = time.monotonic()
        timed_out = []

        def stop_when_late(info) -> bool:
            if time.monotonic() - start > time_limit:
                timed_out.append(info.iteration)
                return True
            return False

        result = form_find(structure, tol=tol if tol > 0 else None,
                           max_iter=max_iter if max_iter > 0 else None, callback=stop_when_late)
    except TensegrityError as err:
        return FormFindReply(message=str(err))
    except Exception as err:  # a bug must become an answer, never a dead service
        return FormFindReply(message=f"internal error: {type(err).__name__}: {err}\n{traceback.format_exc(limit=3)}")
    return FormFindReply(
        success=bool(result.success) and not timed_out,
        message=(f"time limit of {time_limit:g} s reached after {timed_out[0]} iterations; "
                 + result.message) if timed_out else result.message,
        nodes=[[float(v) for v in xyz] for xyz in result.nodes],
        member_forces=[float(t) for t in result.member_forces],
        iterations=int(result.iterations),
        residual=float(result.residual),
        min_stiffness_eigenvalue=float(result.min_eigenvalue),
    )
