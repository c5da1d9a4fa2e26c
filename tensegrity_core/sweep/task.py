"""What a worker does: run a batch of points, one row each, whatever happens to a point.

A row is a plain dict: ``point``, the varied quantities (by column name), ``seed``, the
result columns, ``status``, ``message`` and ``run_time`` [s, wall time of the point on its
worker, without the one-off import of the core modules its computation runs on]. Status:

- ``ok``: the computation succeeded;
- ``failed``: it ran and did not succeed (no stable equilibrium, a run stopped early), or the
  core refused it on the way (a ``TensegrityError``); results are kept as far as they exist;
- ``violated``: it ran, but the outcome breaks an invariant of the physics (an actuator
  length below zero through the fold limit, a stop that pulls); the message says which;
  results are kept, and plots count the point as not ok;
- ``invalid``: the core's loader rejected the point's document (a bad value); the message is
  the loader's;
- ``error``: anything else went wrong in the point (an unexpected exception, named);
- ``lost``: the engine could not get the point's batch run (its workers kept dying); written
  by the engine, not here, and run again by ``--resume``.

BLAS is limited to one thread in every worker process (besides the environment the Dask
nanny sets), so a point's floating-point result does not depend on its worker's load.
"""

from __future__ import annotations

import importlib
import math
import time
from collections.abc import Sequence
from enum import StrEnum
from typing import TYPE_CHECKING, Any

from tensegrity_core.errors import TensegrityError, interrupted
from tensegrity_core.sweep.computations import COMPUTATIONS
from tensegrity_core.sweep.points import Point, apply

if TYPE_CHECKING:
    from tensegrity_core.sweep.spec import Plan

#: A row of the results: column -> plain value.
Row = dict[str, Any]



class RowStatus(StrEnum):
    """What happened to a row's point (see the module docstring); the table holds its text."""

    OK = "ok"
    FAILED = "failed"
    VIOLATED = "violated"
    INVALID = "invalid"
    ERROR = "error"
    LOST = "lost"


#: Statuses that a rerun would give again (``--resume`` keeps them); ``lost`` is rerun.
FINAL_STATUSES = (RowStatus.OK, RowStatus.FAILED, RowStatus.VIOLATED, RowStatus.INVALID, RowStatus.ERROR)
#: The thread-pool limit of this process (False: threadpoolctl missing), once pinned.
_blas_limit: object = None


def pin_blas() -> None:
    """Limit BLAS/OpenMP thread pools of this process to one thread (once per process)."""
    global _blas_limit
    if _blas_limit is None:
        try:
            from threadpoolctl import threadpool_limits
        except ImportError:   # the environment variables of the nanny still apply
            _blas_limit = False
            return
        _blas_limit = threadpool_limits(limits=1)


def missing(dtype: str) -> float | None:
    return math.nan if dtype == "float" else None


def inputs(plan: Plan, point: Point) -> Row:
    """The leading columns of a point's row: index, varied values, seed."""
    row: Row = {"point": point.index}
    row.update({q.column: v for q, v in zip(plan.quantities, point.values)})
    row["seed"] = point.seed
    return row


def run_point(plan: Plan, point: Point) -> Row:
    """The row of one point (never raises for the point's own reasons)."""
    comp = COMPUTATIONS[plan.computation]
    row = inputs(plan, point)
    values: Row = {c: missing(t) for c, t in plan.result_columns}
    t0 = time.perf_counter()
    try:
        document = apply(plan.document, plan.quantities, point.values)
        if plan.sets_seed:
            document["seed"] = point.seed
        try:
            loaded = comp.load(document)
        except TensegrityError as err:
            status, message = RowStatus.INVALID, str(err)
        else:
            ok, message, outcome = comp.run(loaded, plan.options)
            status = RowStatus.OK if ok else RowStatus.FAILED
            broken = comp.violations(outcome)
            if broken:
                status, message = RowStatus.VIOLATED, "; ".join(broken)
            for spec in plan.results:
                got = COMPUTATIONS[plan.computation].results[spec.name].extract(outcome, spec.options, spec.data)
                values.update({c: v for (c, _), v in zip(spec.columns, got)})
    except TensegrityError as err:
        status, message = RowStatus.FAILED, str(err)
    except Exception as err:  # noqa: BLE001 - a point's failure is its row, never the sweep's end
        if interrupted(err):
            raise KeyboardInterrupt from err
        status, message = RowStatus.ERROR, f"{type(err).__name__}: {err}"
    row.update(values)
    row.update(status=status, message=message, run_time=time.perf_counter() - t0)
    return row


def load_modules(plan: Plan) -> None:
    """Import the core modules the plan's computation runs on. A worker's first point would
    otherwise count their import (0.5-0.7 s: scipy and the simulator, against ~0.03 s for a
    point of the shipped examples) in its ``run_time``. A module that cannot be imported is
    left to the points: each meets the same error and its row says so."""
    for name in COMPUTATIONS[plan.computation].modules:
        try:
            importlib.import_module(name)
        except Exception as err:  # noqa: BLE001 - reported by every point's row, not here
            if interrupted(err):
                raise KeyboardInterrupt from err


def run_batch(plan: Plan, points: Sequence[Point]) -> list[Row]:
    """Rows of a batch of points (the task a worker runs)."""
    pin_blas()
    load_modules(plan)
    return [run_point(plan, p) for p in points]
