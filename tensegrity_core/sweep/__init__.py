"""Parameter sweeps and ensembles over scenes and structures, on Dask distributed.

::

    from tensegrity_core.sweep import load_sweep, run_sweep, sweep_names
    sweep = load_sweep("fold_time_kc")        # a shipped name, a path, YAML text or a dict
    table = run_sweep(sweep, output="results.parquet", workers=2)   # pandas DataFrame

A sweep file names a base (a scene or a structure), the quantities to vary by key path into
it (grids, lists, random samples), what to compute at each point (``simulate``,
``form_find``, ``stiffness``, ``ik``) and which scalar results to keep. Reading and checking
sweep files needs only the core; running them needs ``dask[distributed]``, ``pandas`` and
``pyarrow`` (``pip install '.[sweep]'`` in the project's folder), imported only then. See
``docs/sweeps.md``.
"""

from typing import Any

from tensegrity_core.sweep.errors import MissingDependencyError, SweepError
from tensegrity_core.sweep.spec import Plan, Sweep, SweepSource, load_sweep, prepare, sweep_names, sweep_path


def run_sweep(sweep: SweepSource, **kwargs: Any) -> Any:
    """Run a sweep and return its table; see :func:`tensegrity_core.sweep.engine.run_sweep`."""
    from tensegrity_core.sweep.engine import run_sweep as run

    return run(sweep, **kwargs)


__all__ = ["MissingDependencyError", "Plan", "Sweep", "SweepError", "load_sweep", "prepare", "run_sweep",
           "sweep_names", "sweep_path"]
