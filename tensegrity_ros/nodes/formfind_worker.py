"""Form-finding as a separate process for the ``find_form`` service (no ROS in here).

Each request runs in a process forked from a forkserver that has the numerical core
preloaded, so a long request neither holds the node's interpreter lock nor delays other
callers, and a request over its time limit or its memory is stopped without touching the
others. The request's ``structure`` is description *text* and only text: it is parsed by
:func:`tensegrity_core.general.structure_from_text`, which never opens a file, bounded in
size, nesting and aliases (:class:`tensegrity_core.schema.Limits`) and in members
(``max_members``) before the structure is built.

The worker tells the node which phase it is in (``("phase", name)`` on its pipe, the
first as soon as it runs) and ends with ``("result", FormFindReply)``; the node stops a worker that
overruns the time limit, which counts from that first report, parsing included, and names
the phase in its answer.
"""

from __future__ import annotations

import math
import os
import resource
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING

from tensegrity_core.errors import TensegrityError
from tensegrity_core.schema import Limits, clip

if TYPE_CHECKING:
    from tensegrity_core.general.formfind_result import IterationInfo

#: The phases a worker reports, in order (the node names the one a time limit hit).
PARSING = "parsing the structure description"
FORM_FINDING = "form-finding"
#: The longest message an answer carries (characters).
MAX_MESSAGE = 2000
#: What a worker answers when its memory cap stops a request.
OVER_MEMORY = "the request needs more memory than this service allows a worker"
#: The exit code of a worker that could not even send :data:`OVER_MEMORY` (the node answers
#: it for the worker).
OVER_MEMORY_EXIT = 75
#: Exit status of a worker whose node closed its end of the pipe (nobody to answer).
ORPHANED_EXIT = 0
#: Memory set aside before the cap and given back when a request runs out [bytes], so the
#: answer can still be built and pickled: after a MemoryError the freed parse may stay
#: mapped (the allocator keeps it), which counts against the address-space cap.
RESERVE_BYTES = 4 * 2**20


@dataclass
class FormFindReply:
    """What one form-finding request answers (plain values, picklable across the worker's
    pipe): ``nodes`` [[x, y, z], ...] [m] in the description's order, ``member_forces`` [N]
    tension positive, ``residual`` the relative residual (dimensionless: out-of-balance
    force at a node over the forces that meet there), ``residual_norm`` the Euclidean norm
    of all out-of-balance forces and moments [N, N m], ``min_stiffness_eigenvalue`` [N/m,
    mixed with N m/rad where the structure has rigid bodies] and ``stability_margin`` (its scaled value over its rounding level; NaN when not
    computed): see ``FormFindResult``."""

    success: bool = False
    message: str = ""
    nodes: list[list[float]] = field(default_factory=list)
    member_forces: list[float] = field(default_factory=list)
    iterations: int = 0
    residual: float = math.nan
    residual_norm: float = math.nan
    min_stiffness_eigenvalue: float = math.nan
    stability_margin: float = math.nan

    @classmethod
    def failure(cls, message: str) -> FormFindReply:
        """An unsuccessful reply saying ``message`` (at most ``MAX_MESSAGE`` characters)."""
        return cls(message=clip(message, MAX_MESSAGE))


def cap_memory(extra_bytes: int) -> int:
    """Limit this process's address space to what it uses now plus ``extra_bytes``
    (RLIMIT_AS: allocations beyond it fail with MemoryError instead of growing the machine's
    memory); returns the cap [bytes]. The forked worker already maps the preloaded core."""
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[0])
    cap = pages * resource.getpagesize() + int(extra_bytes)
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    return cap


def solve(text: str, tol: float, max_iter: int, time_limit: float, max_members: int, limits: Limits,
          report: Callable[[str], None] = lambda phase: None) -> FormFindReply:
    """Parse a structure description (text) and form-find it; always returns a reply (failures
    too). ``tol`` (on the relative residual) <= 0 and ``max_iter`` == 0 mean the core's
    defaults.
    ``time_limit`` [s] counts from this call: form-finding stops at the first iteration
    past it (the node stops a worker whose parsing runs past it). ``report(phase)`` is
    called as each phase starts.
    """
    from tensegrity_core.general import form_find, structure_from_text

    start = time.monotonic()
    try:
        report(PARSING)
        structure = structure_from_text(text, limits=limits, max_members=max_members)
        report(FORM_FINDING)
        timed_out: list[int] = []

        def stop_when_late(info: IterationInfo) -> bool:
            if time.monotonic() - start > time_limit:
                timed_out.append(info.iteration)
                return True
            return False

        result = form_find(structure, tol=tol if tol > 0 else None,
                           max_iter=max_iter if max_iter > 0 else None, callback=stop_when_late)
    except TensegrityError as err:
        return FormFindReply.failure(str(err))
    except MemoryError:
        return FormFindReply.failure(OVER_MEMORY)
    except Exception as err:  # a bug must become an answer, never a dead service
        traceback.print_exc(file=sys.stderr)            # the server's log, not the caller's answer
        return FormFindReply.failure(f"internal error: {type(err).__name__}")
    return FormFindReply(
        success=bool(result.success) and not timed_out,
        message=clip((f"time limit of {time_limit:g} s reached after {timed_out[0]} iterations; "
                      + result.message) if timed_out else result.message, MAX_MESSAGE),
        nodes=result.nodes.tolist(),
        member_forces=result.member_forces.tolist(),
        iterations=int(result.iterations),
        residual=float(result.residual),
        residual_norm=float(result.residual_norm),
        min_stiffness_eigenvalue=float(result.min_eigenvalue),
        stability_margin=float(result.stability_margin),
    )


def send(conn: Connection, message: tuple[str, object]) -> None:
    """Send ``message`` to the node. When the node's end is closed (it shut down while this
    worker ran) nobody waits for an answer: the worker exits at once, quietly, with
    :data:`ORPHANED_EXIT`."""
    try:
        conn.send(message)
    except (BrokenPipeError, ConnectionResetError):
        os._exit(ORPHANED_EXIT)


def run(conn: Connection, text: str, tol: float, max_iter: int, time_limit: float, max_members: int, limits: Limits,
        memory_bytes: int) -> None:
    """The worker process's body: cap the memory, solve, send phases and the result on ``conn``.
    BLAS takes its memory before the cap (:func:`~tensegrity_core.general.linalg.claim_blas_memory`):
    OpenBLAS retries a failed mapping forever, so under the cap it would hang, not refuse.
    A request that runs out of memory is answered :data:`OVER_MEMORY`; if even that cannot be
    sent, the worker exits at once with :data:`OVER_MEMORY_EXIT` (no traceback to print under
    the cap) and the node answers it. A worker whose node has gone exits (:func:`send`)."""
    from tensegrity_core.general.linalg import claim_blas_memory

    reserve: bytearray | None = bytearray(RESERVE_BYTES)
    try:
        claim_blas_memory()
        cap_memory(memory_bytes)
        reply = solve(text, tol, max_iter, time_limit, max_members, limits,
                      report=lambda phase: send(conn, ("phase", phase)))
        if reply.message == OVER_MEMORY:
            reserve = None
        send(conn, ("result", reply))
    except MemoryError:
        reserve = None
        try:
            send(conn, ("result", FormFindReply.failure(OVER_MEMORY)))
        except MemoryError:
            conn.close()
            os._exit(OVER_MEMORY_EXIT)
    finally:
        del reserve
        conn.close()
