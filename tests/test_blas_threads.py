"""The run's BLAS thread count (tests/conftest.py): numpy's and scipy's OpenBLAS both run on
the run's threads (one unless OPENBLAS_NUM_THREADS asks for more, at most one per core this
process may use, as OpenBLAS caps it) in every worker, whichever test files it ran before; the
setting is in the environment every process the run starts gets."""

from __future__ import annotations

import os


def test_both_blas_libraries_run_on_the_runs_threads():
    import numpy  # noqa: F401  (each loads its own OpenBLAS)
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_info

    threads = min(int(os.environ["OPENBLAS_NUM_THREADS"]), len(os.sched_getaffinity(0)))
    blas = [pool for pool in threadpool_info() if pool["user_api"] == "blas"]
    assert len(blas) == 2 and {pool["num_threads"] for pool in blas} == {threads}
